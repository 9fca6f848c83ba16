"""The synthetic face: mesh, linear model, targets, deterministic rendering, true flow, mask."""

from __future__ import annotations

import hashlib
import subprocess
import sys

import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.visemes import default_table
from synth_face import Face, FaceRenderer
from synth_face.raster import rasterize
from synth_face.validate import alignment_offset, grey, warp_residual


@pytest.fixture(scope="module")
def face() -> Face:
    return Face()


@pytest.fixture(scope="module")
def r128(face: Face):
    with FaceRenderer(face, 128) as r:
        yield r


@pytest.fixture(scope="module")
def r256(face: Face):
    with FaceRenderer(face, 256) as r:
        yield r


def _part_of_pixels(face: Face, renderer: FaceRenderer, params: np.ndarray) -> np.ndarray:
    """Name index (into face.parts) of the part each pixel shows, -1 on the background."""
    ra = rasterize(renderer.camera.project(face.vertices(params)), face.triangles, renderer.size)
    offsets = np.cumsum([0] + [p.triangles.shape[0] for p in face.parts])
    part = np.searchsorted(offsets, ra.tri, side="right") - 1
    return np.where(ra.tri >= 0, part, -1)


# --- mesh and model -------------------------------------------------------------------------


def test_mesh_is_dense_around_the_mouth(face: Face) -> None:
    assert face.triangles.shape[0] >= 10_000
    names = [p.name for p in face.parts]
    assert names == ["skin", "upper_teeth", "lower_teeth", "tongue", "cavity"]
    skin = face.parts[0]
    centroids = skin.rest[skin.triangles].mean(axis=1)
    r = np.hypot(centroids[:, 0] / 1.6, centroids[:, 1])  # the mouth is wide
    near = (r < 12).sum() / (np.pi * 12**2 * 1.6)  # triangles per mm² near the lips
    far = ((r > 40) & (r < 50)).sum() / (np.pi * (50**2 - 40**2) * 1.6)
    assert near > 4 * far


def test_vertices_are_linear_in_the_parameters(face: Face) -> None:
    rng = np.random.default_rng(0)
    pa, pb = rng.uniform(0, 1, face.n_params), rng.uniform(0, 1, face.n_params)
    va, vb = face.vertices(pa), face.vertices(pb)
    for a in (0.0, 0.3, 0.75, 1.0):
        np.testing.assert_allclose(face.vertices((1 - a) * pa + a * pb), (1 - a) * va + a * vb)
    np.testing.assert_array_equal(face.vertices(np.zeros(face.n_params)), face.rest)
    # teeth and tongue belong to the model: the jaw carries the lower teeth and the tongue
    jaw = face.params(jaw_open=1.0)
    moved = np.abs(face.vertices(jaw) - face.rest).max(axis=1)
    assert moved[face.vertex_slices["lower_teeth"]].min() > 5.0
    assert moved[face.vertex_slices["tongue"]].min() > 5.0
    assert moved[face.vertex_slices["upper_teeth"]].max() == 0.0


def test_params_are_validated(face: Face) -> None:
    assert face.param_names[:2] == ("jaw_open", "lip_part")
    assert len(face.param_names) >= 6
    with pytest.raises(MiketalkError, match="shape"):
        face.vertices(np.zeros(3))
    with pytest.raises(MiketalkError, match="out of range"):
        face.vertices(face.params() + 2.0)
    with pytest.raises(MiketalkError, match="unknown face parameter"):
        face.params(smile=1.0)


def test_jaw_motion_and_framing(face: Face, r256: FaceRenderer) -> None:
    a = face.parts[0].attrs
    on_slit = (a["mu"] == 0) & (a["sigma"] == 0)
    lower_mid = np.flatnonzero(on_slit & np.isclose(a["nu"], 1.5 * np.pi))[0]
    corners = np.flatnonzero(on_slit & (np.isclose(a["nu"], 0.0) | np.isclose(a["nu"], np.pi)))
    cam = r256.camera
    rest = cam.project(face.vertices(face.params()))
    jaw = cam.project(face.vertices(face.params(jaw_open=1.0)))
    assert 15.0 <= jaw[lower_mid, 1] - rest[lower_mid, 1] <= 25.0  # px at 256²
    width = abs(rest[corners[0], 0] - rest[corners[1], 0]) / cam.size
    assert 0.35 <= width <= 0.45


# --- targets --------------------------------------------------------------------------------


def test_every_corpus_target_has_a_pose(face: Face) -> None:
    table = default_table()
    assert len(table.targets) == 53
    for t in table.targets:
        p = face.target(t.key)
        assert p.dtype == np.float64 and p.shape == (face.n_params,)
        face.check_params(p)
    np.testing.assert_array_equal(face.target("b"), face.target("p"))
    assert not face.target("#").any()
    with pytest.raises(MiketalkError, match="unknown corpus target"):
        face.target("zz")


def test_phone_targets(face: Face) -> None:
    (iy,) = face.phone_targets("iy")
    np.testing.assert_array_equal(iy, face.target("ii"))
    ow = face.phone_targets("ow")
    assert len(ow) == 2
    np.testing.assert_array_equal(ow[0], face.target("ou:1"))
    np.testing.assert_array_equal(ow[1], face.target("ou:2"))
    np.testing.assert_array_equal(face.phone_targets("hh")[0], face.target("h"))
    np.testing.assert_array_equal(face.phone_targets("pau")[0], face.target("#"))
    with pytest.raises(MiketalkError, match="unknown phone"):
        face.phone_targets("xx")


def test_grouped_phones_look_alike_and_groups_differ(face: Face, r128: FaceRenderer) -> None:
    mask = r128.mouth_mask()
    table = face.table
    pixels = {t.key: grey(r128.render(face.target(t.key)))[mask] for t in table.targets}

    def dist(a: str, b: str) -> float:
        return float(np.abs(pixels[a] - pixels[b]).mean())

    assert dist("b", "p") == 0.0
    assert dist("b", "m") < dist("b", "aa")
    assert dist("t", "s") < dist("t", "aa")
    assert dist("f", "v") < dist("f", "ii")
    # every target is nearer its own viseme's image than any other viseme's
    reps = {v: table.representative(v).key for v in table.visemes}
    for t in table.targets:
        d = {v: dist(t.key, k) for v, k in reps.items()}
        assert min(d, key=d.get) == t.viseme, (t.key, t.viseme, d)


# --- rendering ------------------------------------------------------------------------------


def test_render_is_deterministic(face: Face, r128: FaceRenderer) -> None:
    p = face.target("oo")
    a = r128.render(p)
    r128.render(face.target("aa"))
    b = r128.render(p)
    assert a.shape == (128, 128, 3) and a.dtype == np.uint8
    assert a.tobytes() == b.tobytes()
    code = (
        "import hashlib\n"
        "from synth_face import Face, FaceRenderer\n"
        "f = Face()\n"
        "with FaceRenderer(f, 128) as r:\n"
        "    print(hashlib.sha256(r.render(f.target('oo')).tobytes()).hexdigest())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == hashlib.sha256(a.tobytes()).hexdigest()


def test_render_shows_the_mouth(face: Face, r128: FaceRenderer) -> None:
    closed = r128.render(face.target("#"))
    wide = r128.render(face.target("aa"))
    mask = r128.mouth_mask()
    # an open mouth is dark inside; texture everywhere on the skin
    assert grey(wide)[mask].min() < grey(closed)[mask].min() - 20
    skin = _part_of_pixels(face, r128, face.target("#")) == 0
    assert grey(closed)[skin].std() > 10


def test_render_512_and_errors(face: Face) -> None:
    with FaceRenderer(face, 512) as r:
        img = r.render(face.target("ii"))
        assert img.shape == (512, 512, 3)
    with pytest.raises(MiketalkError, match="closed"):
        r.render(face.target("ii"))
    with pytest.raises(MiketalkError, match="size"):
        FaceRenderer(face, 8)


# --- true flow ------------------------------------------------------------------------------


def test_true_flow_of_a_rigid_rotation_is_the_homography(face: Face, r128: FaceRenderer) -> None:
    p = face.target("e")
    rot = r128.camera.rotation_about_center(0.5, -0.4)
    flow, valid = r128.true_flow(p, p, rigid_b=rot)
    assert flow.dtype == np.float32 and flow.shape == (128, 128, 2) and valid.dtype == bool
    expect = r128.camera.homography_flow(rot)
    assert np.abs(expect).max() > 3.0
    assert np.abs(flow - expect)[valid].max() < 0.05
    # a rotation about the camera centre hides nothing: all of the face stays valid
    face_px = _part_of_pixels(face, r128, p) >= 0
    inside = np.zeros_like(valid)
    inside[6:-6, 6:-6] = True
    assert valid[face_px & inside].all()
    assert not valid[~face_px].any()


def test_true_flow_of_a_rigid_translation(face: Face, r128: FaceRenderer) -> None:
    p = face.target("#")
    shift = np.eye(4)
    shift[:3, 3] = (2.0, 1.0, 0.0)
    flow, valid = r128.true_flow(p, p, rigid_b=shift)
    cam = r128.camera
    depth = rasterize(cam.project(face.vertices(p)), face.triangles, cam.size).depth
    expect = np.stack([2.0 * cam.focal_px / depth, -1.0 * cam.focal_px / depth], axis=-1)
    assert valid.mean() > 0.7
    assert np.abs(flow - expect)[valid].max() < 0.05


def test_zero_motion_is_zero_flow(face: Face, r128: FaceRenderer) -> None:
    p = face.target("ch")
    flow, valid = r128.true_flow(p, p)
    assert np.abs(flow).max() < 1e-6
    assert np.array_equal(valid, _part_of_pixels(face, r128, p) >= 0)


def test_warp_back_reproduces_a(face: Face, r256: FaceRenderer) -> None:
    # rigid: only resampling noise, and the flow is aligned with the renderer
    p = face.target("#")
    rot = r256.camera.rotation_about_center(0.4, -0.3)
    flow, valid = r256.true_flow(p, p, rigid_b=rot)
    a, b = r256.render(p), r256.render(p, rigid=rot)
    res, base = warp_residual(a, b, flow, valid)
    assert res < 2.0 < 5.0 < base
    ox, oy = alignment_offset(a, b, flow, valid)
    assert abs(ox) < 0.1 and abs(oy) < 0.1
    # a pose change: shading changes with the normals, still far below no warp
    pa, pb = face.target("k"), face.target("e")
    flow, valid = r256.true_flow(pa, pb)
    res, base = warp_residual(r256.render(pa), r256.render(pb), flow, valid)
    assert res < 2.0 and res < 0.35 * base


def test_warp_back_in_albedo_mode_is_resampling_noise(face: Face) -> None:
    with FaceRenderer(face, 256, lighting="albedo") as r:
        pa, pb = face.target("#"), face.target("aa")
        flow, valid = r.true_flow(pa, pb)
        res, base = warp_residual(r.render(pa), r.render(pb), flow, valid, region=r.mouth_mask())
    assert res < 2.5 and res < 0.1 * base


def test_mask_on_a_closing_mouth(face: Face, r128: FaceRenderer) -> None:
    open_, closed = face.target("aa"), face.target("#")
    flow, valid = r128.true_flow(open_, closed)
    parts = _part_of_pixels(face, r128, open_)
    inside = parts >= 1  # teeth, tongue, cavity: hidden once the lips close
    assert inside.sum() > 100
    assert not valid[inside].any()
    assert not valid[parts < 0].any()  # background
    # most of the lips stay visible and move by up to the jaw's travel
    lips = r128.mouth_mask() & (parts == 0)
    assert valid[lips].mean() > 0.9
    assert 5.0 < np.abs(flow[..., 1][lips & valid]).max() < 20.0
    # the opposite direction: everything of the closed mouth is still visible when open
    flow, valid = r128.true_flow(closed, open_)
    face_px = _part_of_pixels(face, r128, closed) == 0
    assert valid[face_px & r128.mouth_mask()].mean() > 0.97


def test_mouth_mask(face: Face, r128: FaceRenderer) -> None:
    m = r128.mouth_mask()
    assert m.shape == (128, 128) and m.dtype == bool
    assert 0.04 < m.mean() < 0.3
    r128.render(face.target("aa"))
    assert np.array_equal(m, r128.mouth_mask())
    # it covers the opening and the lips of every pose
    for key in ("aa", "ii", "uu", "f"):
        parts = _part_of_pixels(face, r128, face.target(key))
        assert m[(parts >= 1)].all()
