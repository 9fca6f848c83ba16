"""The model a face speaks with, on disk: its viseme images and flows, its manifest, what else
it holds (``parts``), written (``write``) and read (``face``)."""
