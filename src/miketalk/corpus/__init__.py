"""The corpus stage: recordings in, the corpus folder out, viseme frames found in it."""
