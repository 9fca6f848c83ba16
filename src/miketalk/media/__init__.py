"""Files in and out: images, audio, video, and atomic writes."""
