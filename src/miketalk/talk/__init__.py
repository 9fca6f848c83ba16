"""Saying things: text or a recording in, the face's mp4 and its timeline out (``say``,
``recorded``), written as one unit (``utterance``, ``output``)."""
