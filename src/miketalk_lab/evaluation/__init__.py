"""Measuring: truth, image and sync measures, flow error, morph fidelity, sync."""
