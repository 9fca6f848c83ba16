"""Compositing onto video: the person's own frames under the mouth (``background``, its files
and its ``loop``), the checks a video must pass to carry the mouth (``video_checks``), and the
mouth rendered in the reference frame placed into each frame (``compositor``, ``follow``)."""
