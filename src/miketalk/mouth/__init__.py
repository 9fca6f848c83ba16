"""Mouth features of a person's frames, shared by model building and evaluation.

- :mod:`~miketalk.mouth.region`: the mouth box and the regions about it, grey
  mouth boxes, the mouth's opening (mean darkness);
- :mod:`~miketalk.mouth.eigenlips`: principal components of mouth boxes.
"""

from miketalk.mouth.eigenlips import N_EIGENLIPS, Eigenlips
from miketalk.mouth.region import (
    flow_region,
    grey_mouths,
    mouth_box,
    mouth_opening,
    mouth_region,
)

__all__ = [
    "N_EIGENLIPS",
    "Eigenlips",
    "flow_region",
    "grey_mouths",
    "mouth_box",
    "mouth_opening",
    "mouth_region",
]
