"""Lip-sync planning: timed phones to a timeline of viseme transitions and morph parameters.

``timeline`` (the paper's §7: transitions and a morph parameter per frame),
``sampling`` (fast transitions blurred, oversampled, or not), ``motion`` (an
utterance's speed and steps measured), ``cues`` (mouth cues and TextGrids for other
tools) and ``settings`` (the lip-sync settings, their vocabularies and ranges).
"""
