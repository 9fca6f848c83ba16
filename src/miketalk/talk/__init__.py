"""Talking: lip-sync timelines, the talking-face model, and `say`."""
