"""Building a face's model from clips or one video: the workflow's stages, one function each."""
