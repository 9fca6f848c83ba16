"""Figures: plots of the metrics and sheets of images."""
