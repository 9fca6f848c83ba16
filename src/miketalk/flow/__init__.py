"""Optical flow for viseme morphing (the paper's sections 5.1-5.2 and its Appendix).

Flows follow the package convention (see :mod:`miketalk`): ``(H, W, 2)``
float32, ``[..., 0]`` = dx, ``[..., 1]`` = dy, and the flow from A to B
satisfies ``A(p) ~ B(p + flow(p))`` (the paper's C_0, Eq. 1).

Modules, one job each:

``bergen``     the paper's coarse-to-fine gradient-based estimator
``pyramid``    the coarse-to-fine loop it plugs into
``opencv``     OpenCV's DIS, Farneback, DeepFlow and TV-L1 behind the same signature
``registry``   names -> estimators with default settings (what config.yaml names)
``warp``       backward warp (Fig. 9)
``concat``     flow concatenation (Eq. 11, Figs. 10 and 11)
``mixed``      direct + concatenated flow for visemes far apart (section 5.2)
``exr``        one pair's two flows in an OpenEXR file
``database``   pair-file naming and the :class:`FlowDatabase` reader
``flo``        Middlebury ``.flo`` export and import
``build``      the flow database of a recording's visemes (a pool over strategies)

Examples
--------
>>> from miketalk.flow import get_estimator
>>> est = get_estimator("bergen", levels=4)   # est(image_a, image_b) -> flow
"""

from miketalk.flow.bergen import bergen_flow
from miketalk.flow.concat import (
    concat_flows,
    concatenate_down,
    concatenate_down_flows,
    concatenate_up,
    concatenate_up_flows,
    consecutive_flows,
)
from miketalk.flow.database import FlowDatabase, pair_filename, pair_path
from miketalk.flow.exr import FlowPair, read_flow_header, read_flow_pair, write_flow_pair
from miketalk.flow.flo import read_flo, write_flo
from miketalk.flow.mixed import MixedFlowInfo, mixed_flow, window_chains
from miketalk.flow.opencv import deepflow_flow, dis_flow, farneback_flow, tvl1_flow
from miketalk.flow.registry import ESTIMATORS, Estimator, get_estimator
from miketalk.flow.warp import backward_warp

__all__ = [
    "ESTIMATORS",
    "Estimator",
    "FlowDatabase",
    "FlowPair",
    "MixedFlowInfo",
    "backward_warp",
    "bergen_flow",
    "concat_flows",
    "concatenate_down",
    "concatenate_down_flows",
    "concatenate_up",
    "concatenate_up_flows",
    "consecutive_flows",
    "deepflow_flow",
    "dis_flow",
    "farneback_flow",
    "get_estimator",
    "mixed_flow",
    "pair_filename",
    "pair_path",
    "read_flo",
    "read_flow_header",
    "read_flow_pair",
    "tvl1_flow",
    "window_chains",
    "write_flo",
    "write_flow_pair",
]
