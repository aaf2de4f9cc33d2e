"""Coordinate frames: transforms as data, composition, YAML files, Vicon-style calibration."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from fleet_common.errors import TransformError
from fleet_common.frames import (
    Transform2D,
    dump_transforms,
    find_transform,
    fit_similarity,
    load_transforms,
    mapf_ir_to_base,
    parse_transforms,
    scale_translate,
    similarity,
)

CHAIN = ("mapf-ir", "base", "robot", "vicon")  # frames in an order transforms can chain

finite = st.floats(-1e3, 1e3, allow_nan=False)
log_scales = st.floats(-3, 3)  # scales from 0.001 to 1000


@st.composite
def affines(draw: st.DrawFn, source: str = "base", target: str = "robot") -> Transform2D:
    """Well-conditioned affine maps: mirror?, non-uniform scale, rotation, shear, shift."""
    sx = 10 ** draw(log_scales)
    sy = sx * 10 ** draw(st.floats(-1, 1))
    theta = draw(st.floats(-math.pi, math.pi))
    shear = draw(st.floats(-2, 2))
    c, s = math.cos(theta), math.sin(theta)
    linear = np.array([[c, -s], [s, c]]) @ np.array([[sx, shear * sx], [0, sy]])
    if draw(st.booleans()):
        linear = linear @ np.diag([1.0, -1.0])
    m = np.eye(3)
    m[:2, :2] = linear
    m[:2, 2] = (draw(finite), draw(finite))
    return Transform2D(m, source, target)


points = st.lists(st.tuples(finite, finite), min_size=1, max_size=20).map(np.array)


def test_lab_constructors_map_known_points() -> None:
    flip = mapf_ir_to_base(14)
    assert (flip.source, flip.target) == ("mapf-ir", "base")
    assert flip.apply((0, 0)) == (0.0, 13.0)  # mapf-IR's top-left is the base's top-left
    assert flip.apply((12, 13)) == (12.0, 0.0)
    to_robot = scale_translate(0.7, 0.7, 2.1, "base", "robot")
    assert np.allclose(to_robot.apply([[0, 0], [12, 13], [6, 5]]),
                       [[0.7, 2.1], [9.1, 11.2], [4.9, 5.6]])
    quarter = similarity(2.0, math.pi / 2, 1.0, 0.0, "vicon", "base")
    assert np.allclose(quarter.apply((1.0, 0.0)), (1.0, 2.0))  # counter-clockwise


@given(affines(), points)
def test_inverse_undoes_the_transform(t: Transform2D, pts: np.ndarray) -> None:
    back = t.inverse()
    assert (back.source, back.target) == (t.target, t.source)
    assert np.allclose(back.apply(t.apply(pts)), pts, atol=1e-6)
    assert t.then(back).is_close(Transform2D.identity("base"), atol=1e-7)


@given(affines(CHAIN[0], CHAIN[1]), affines(CHAIN[1], CHAIN[2]), affines(CHAIN[2], CHAIN[3]),
       points)
def test_composition_is_associative_and_a_matrix_product(
    a: Transform2D, b: Transform2D, c: Transform2D, pts: np.ndarray
) -> None:
    left, right = a.then(b).then(c), a.then(b.then(c))
    assert (left.source, left.target) == ("mapf-ir", "vicon")
    product = c.matrix @ b.matrix @ a.matrix
    scale = np.abs(product).max()
    assert np.allclose(left.matrix, product, rtol=1e-9, atol=1e-9 * scale)
    assert np.allclose(right.matrix, product, rtol=1e-9, atol=1e-9 * scale)
    sequential = c.apply(b.apply(a.apply(pts)))
    assert np.allclose(left.apply(pts), sequential, rtol=1e-9, atol=1e-6 * scale)


def test_composing_frames_that_do_not_meet_is_refused() -> None:
    to_robot = scale_translate(0.7, 0.7, 2.1, "base", "robot")
    with pytest.raises(TransformError, match="cannot compose base->robot with mapf-ir->base"):
        to_robot.then(mapf_ir_to_base(14))


@given(affines())
def test_dict_form_round_trips(t: Transform2D) -> None:
    d = t.to_dict()
    # Every transform without shear is written readably, a sheared one as a matrix.
    assert ("matrix" in d) == (t.parts() is None)
    assert Transform2D.from_dict(d).is_close(t, atol=1e-9 * np.abs(t.matrix).max())


def test_lab_transform_is_written_readably(tmp_path: Path) -> None:
    path = tmp_path / "frames.yaml"
    text = dump_transforms({"base_to_robot": scale_translate(0.7, 0.7, 2.1, "base", "robot"),
                            "mapf_ir_to_base": mapf_ir_to_base(14)}, path)
    assert "scale: 0.7\n" in text and "translation: [0.7, 2.1]" in text
    assert "translation: [0.0, 13.0]\n  flip_y: true" in text
    loaded = load_transforms(path)
    assert loaded["base_to_robot"] == scale_translate(0.7, 0.7, 2.1, "base", "robot")
    assert loaded["mapf_ir_to_base"].apply((3, 0)) == (3.0, 13.0)


def test_find_transform_chains_entries_and_inverses() -> None:
    vicon_to_base = similarity(1 / 700, 0.1, 2.0, -1.0, "vicon", "base")
    base_to_robot = scale_translate(0.7, 0.7, 2.1, "base", "robot")
    vicon_to_robot = find_transform([vicon_to_base, base_to_robot], "vicon", "robot")
    p = (1234.0, -567.0)
    assert np.allclose(vicon_to_robot.apply(p), base_to_robot.apply(vicon_to_base.apply(p)))
    robot_to_vicon = find_transform([vicon_to_base, base_to_robot], "robot", "vicon")
    assert np.allclose(robot_to_vicon.apply(vicon_to_robot.apply(p)), p)
    with pytest.raises(TransformError, match="no transform from base to mapf-ir"):
        find_transform([base_to_robot], "base", "mapf-ir")


# ---- transforms files: errors name the file, the line and what was expected ----

GOOD_ENTRY = "t:\n  source: base\n  target: robot\n"


@pytest.mark.parametrize(
    "text, line, fragment",
    [
        ("t:\n  source: base\n\ttarget: robot\n", 3, "not valid YAML"),
        ("- source: base\n", 1, "expected a mapping of transform names"),
        ("t: 0.7\n", 1, "transform 't' must be a mapping"),
        (GOOD_ENTRY + "  rotation: 90\n", 4, "unknown key 'rotation': expected source, target"),
        ("t:\n  source: base\n  scale: 2\n", 2, "missing key 'target'"),
        ("t:\n  source: base\n  target: robots\n", 3,
         "unknown target frame 'robots': expected one of base, mapf-ir, robot, vicon"),
        (GOOD_ENTRY + "  scale: 2\n  matrix: [[1, 0, 0], [0, 1, 0]]\n", 4,
         "give either matrix or scale/rotation_deg/translation/flip_y, not both"),
        (GOOD_ENTRY + "  scale: -0.7\n", 4, "scale must be positive (mirror with flip_y)"),
        (GOOD_ENTRY + "  scale: big\n", 4, "scale must be a finite number, got 'big'"),
        (GOOD_ENTRY + "  rotation_deg: .inf\n", 4, "rotation_deg must be a finite number"),
        (GOOD_ENTRY + "  translation: [1, 2, 3]\n", 4, "translation must be a list of 2 numbers"),
        (GOOD_ENTRY + "  flip_y: maybe\n", 4, "flip_y must be true or false"),
        (GOOD_ENTRY + "  matrix:\n  - [1, 0, 0]\n  - [0, 1]\n", 6,
         "matrix row 2 must be a list of 3 numbers"),
        (GOOD_ENTRY + "  matrix: [[1, 2, 0], [2, 4, 0]]\n", 4, "transform is singular"),
        (GOOD_ENTRY + "  matrix: [[1, 0, 0], [0, 1, 0], [0, 1, 1]]\n", 4,
         "the last matrix row must be 0 0 1"),
        (GOOD_ENTRY + "u:\n  source: base\n  target: base\nt:\n  source: base\n", 7,
         "duplicate key 't' (first on line 1)"),
    ],
)
def test_malformed_transforms_file(tmp_path: Path, text: str, line: int, fragment: str) -> None:
    path = tmp_path / "frames.yaml"
    path.write_text(text)
    with pytest.raises(TransformError) as err:
        load_transforms(path)
    assert err.value.path == str(path)
    assert err.value.line == line
    assert fragment in err.value.message
    assert str(err.value).startswith("{}:{}:".format(path, line))


def test_missing_transforms_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(TransformError, match="nope.yaml: cannot read"):
        load_transforms(tmp_path / "nope.yaml")


def test_empty_transforms_file_holds_no_transforms() -> None:
    assert parse_transforms("# nothing calibrated yet\n") == {}


# ---- calibration ----------------------------------------------------------------

@st.composite
def calibrations(draw: st.DrawFn) -> tuple:
    """A random similarity and 3..8 measured points spread in both directions."""
    truth = similarity(10 ** draw(log_scales), draw(st.floats(-math.pi, math.pi)),
                       draw(finite), draw(finite), "vicon", "base")
    n = draw(st.integers(3, 8))
    src = np.array(draw(st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)),
                                 min_size=n, max_size=n, unique=True)), dtype=float)
    spread = np.linalg.svd(src - src.mean(axis=0), compute_uv=False)
    assume(spread[1] > 0.2 * spread[0])
    return truth, src


@given(calibrations())
def test_fit_recovers_an_exact_similarity_with_zero_residual(case: tuple) -> None:
    truth, src = case
    fitted, residual = fit_similarity(src, truth.apply(src), "vicon", "base")
    scale = np.abs(truth.matrix[:2, :2]).max()
    assert (fitted.source, fitted.target) == ("vicon", "base")
    assert residual <= 1e-9 * max(1.0, scale * 100)
    assert np.allclose(fitted.matrix, truth.matrix, rtol=1e-7, atol=1e-7 * max(1.0, scale * 100))


@given(calibrations(), st.integers(0, 2**32 - 1))
def test_fit_recovers_a_similarity_from_noisy_points(case: tuple, seed: int) -> None:
    truth, src = case
    dst = truth.apply(src)
    extent = float(np.ptp(dst, axis=0).max())
    noise = np.random.default_rng(seed).normal(0.0, 1e-4 * extent, size=dst.shape)
    fitted, residual = fit_similarity(src, dst + noise, "vicon", "base")
    assert residual <= 1e-3 * extent
    (sx, _), rotation, _, flip = fitted.parts()
    (true_sx, _), true_rotation, _, _ = truth.parts()
    assert not flip
    assert sx == pytest.approx(true_sx, rel=1e-2)
    assert abs((rotation - true_rotation + 180) % 360 - 180) < 0.5
    assert np.abs(fitted.apply(src) - dst).max() <= 1e-2 * extent


@pytest.mark.parametrize(
    "src, dst, fragment",
    [
        ([[0, 0], [1, 0]], [[0, 0], [2, 0]], "needs at least 3 point pairs, got 2"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 0], [1, 0]], "got 3 source points but 2 target points"),
        ([[0, 0], [1, 0], [0, 0], [0, 1]], [[0, 0], [1, 0], [5, 5], [0, 1]],
         "source points 0 and 2 coincide"),
        ([[0, 0], [1, 1], [2, 2.0005]], [[0, 0], [1, 0], [0, 1]],
         "source points are (nearly) collinear"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 0], [2, 0], [4, 0]],
         "target points are (nearly) collinear"),
        ([[0, 0], [1, 0], [0, 1], [1, 1]], [[0, 0], [0, 1], [1, 0], [1, 1]], "mirror image"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0], [1, 0], [0, 1]], "(N, 2) array"),
    ],
)
def test_fit_rejects_unusable_point_sets(src: list, dst: list, fragment: str) -> None:
    with pytest.raises(TransformError) as err:
        fit_similarity(src, dst, "vicon", "base")
    assert fragment in str(err.value)
