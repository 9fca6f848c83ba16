"""miketalk: text-to-audiovisual speech by morphing visemes (Ezzat & Poggio, 1999).

Conventions (stated here once; every module follows them)
---------------------------------------------------------
Images
    ``(H, W)`` grey or ``(H, W, 3)`` RGB arrays, row-major, origin at the top-left
    pixel centre. uint8 on disk; float32 in ``[0, 1]`` or uint8 in memory as each
    function documents.
Flows
    ``(H, W, 2)`` float32. ``flow[..., 0]`` is dx (along columns, x) and
    ``flow[..., 1]`` is dy (along rows, y). The flow of pixel ``p = (x, y)`` in
    image A points to its match in image B: ``A(p) ~ B(p + flow(p))``. This is the
    paper's correspondence map C_0 (its Eq. 1). A flow "from A to B" is the
    forward flow of the pair; "from B to A" the backward flow.
Times
    Seconds as float; audio samples as int16 mono at the utterance's rate.
Errors
    Mistakes a user can make (bad text, missing files, bad settings) raise
    :class:`miketalk.errors.MiketalkError` with a message that says what to do;
    the CLI prints that message without a traceback.
"""

__version__ = "0.1.0"
