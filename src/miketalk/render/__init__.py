"""Rendering: drawing frames of the face (compositing a mouth into video frames)."""
