"""Vicon calibration: the fit, the correspondences file, writing frames.yaml, the command."""
from __future__ import annotations

import math
import shutil
import subprocess
import sys
from pathlib import Path
from typing import List, Tuple

import numpy as np
import pytest

from fleet_common.errors import TransformError
from fleet_common.frames import (dump_transforms, load_transforms, scale_translate,
                                 set_transform, similarity)
from fleet_common.lab import lab_frames_path, lab_transforms
from fleet_common.vicon.calibration import (Correspondence, calibrate, format_correspondences,
                                            parse_correspondences)
from helpers import fleetctl, free_port

LAB_CELLS = [(x, y) for x in range(13) for y in range(14)]


def truth_and_pairs(seed: int, n: int, sigma_mm: float = 5.0) -> Tuple[object, List[Correspondence]]:
    """A random lab-like similarity base -> vicon and `n` robots on distinct cells, measured
    with Gaussian noise of `sigma_mm` on each coordinate."""
    rng = np.random.default_rng(seed)
    base_to_vicon = similarity(rng.uniform(600.0, 800.0), rng.uniform(-math.pi, math.pi),
                               rng.uniform(-5000, 5000), rng.uniform(-5000, 5000),
                               "base", "vicon")
    cells = [LAB_CELLS[i] for i in rng.choice(len(LAB_CELLS), size=n, replace=False)]
    seen = base_to_vicon.apply(np.array(cells, dtype=float)) + rng.normal(0, sigma_mm, (n, 2))
    return base_to_vicon, [Correspondence(tuple(map(float, c)), (float(v[0]), float(v[1])),
                                          "r{}".format(i)) for i, (c, v) in enumerate(zip(cells, seen))]


# fixed seeds: the noise is random, the test is not
@pytest.mark.parametrize("seed", range(25))
def test_recovers_a_random_similarity_from_noisy_correspondences(seed: int) -> None:
    truth, pairs = truth_and_pairs(seed, n=4 + seed % 9)
    result = calibrate(pairs)
    assert result.rms_cm < 1.0
    assert len(result.residuals_cm) == len(pairs) and max(result.residuals_cm) < 2.5
    (scale, _), rotation, _, flip = truth.parts()
    assert result.mm_per_cell == pytest.approx(scale, rel=0.01) and not flip
    assert abs(math.remainder(result.rotation_deg + rotation, 360.0)) < 0.5
    # every cell of the lab comes back within 2 cm of where Vicon would put it
    cells = np.array(LAB_CELLS, dtype=float)
    error_mm = np.linalg.norm(result.transform.inverse().apply(cells) - truth.apply(cells), axis=1)
    assert error_mm.max() < 20.0


@pytest.mark.parametrize("seed", range(10))
def test_one_wrong_correspondence_pushes_the_rms_over_the_threshold(seed: int) -> None:
    _, pairs = truth_and_pairs(seed, n=6)
    a, b = pairs[0], pairs[1]  # two robots' cells swapped: each robot is given the other's
    wrong = [Correspondence(b.cell, a.vicon, a.label), Correspondence(a.cell, b.vicon, b.label)]
    result = calibrate(wrong + pairs[2:])
    assert result.rms_cm > 2.0
    used = {p.cell for p in pairs}
    near = next((x + dx, y) for x, y in [pairs[5].cell] for dx in (1, -1, 2, -2)
                if (x + dx, y) not in used)  # one robot a cell or two off
    assert calibrate(pairs[:5] + [Correspondence(near, pairs[5].vicon, "off")]).rms_cm > 2.0


def test_fewer_than_four_pairs_are_refused() -> None:
    _, pairs = truth_and_pairs(1, n=3)
    with pytest.raises(TransformError, match="at least 4 correspondences"):
        calibrate(pairs)


def test_correspondences_file_round_trips_and_names_bad_lines() -> None:
    _, pairs = truth_and_pairs(3, n=5)
    text = format_correspondences(pairs)
    again = parse_correspondences(text, "c.txt")
    assert [(p.cell, p.label) for p in again] == [(p.cell, p.label) for p in pairs]
    assert np.allclose([p.vicon for p in again], [p.vicon for p in pairs], atol=0.005)
    for bad, line, column, fragment in [
            ("1 2 3\n", 1, None, "expected 4 or 5 fields"),
            ("# c\n1 2 3 4 x y\n", 2, None, "found 6"),
            ("1 2 3 nan\n", 1, 7, "bad vicon_y_mm 'nan'"),
            ("1  two 3 4\n", 1, 4, "bad cell_y 'two'")]:
        with pytest.raises(TransformError) as err:
            parse_correspondences(bad, "c.txt")
        assert (err.value.path, err.value.line, err.value.column) == ("c.txt", line, column)
        assert fragment in err.value.message


# ---- writing into a frames file ------------------------------------------------------------

def test_set_transform_replaces_one_entry_and_keeps_the_rest_and_the_comments() -> None:
    text = lab_frames_path().read_text()
    new = similarity(1 / 650.0, 0.3, 2.0, -1.0, "vicon", "base")
    out = set_transform(text, "vicon_to_base", new, "fitted today: 5 points")
    loaded = {k: v for k, v in load_transforms_text(out).items()}
    assert loaded["vicon_to_base"].is_close(new)
    assert loaded["base_to_robot"] == lab_transforms()["base_to_robot"]
    comments = [line for line in text.splitlines() if line.startswith("#")]
    assert all(c in out.splitlines() for c in comments)
    assert "  # fitted today: 5 points" in out
    # written again, the entry is replaced, not repeated
    twice = set_transform(out, "vicon_to_base", new, "again")
    assert twice.count("vicon_to_base:") == 1 and "fitted today" not in twice


def test_set_transform_adds_a_missing_entry_and_copes_with_flow_style() -> None:
    new = similarity(1 / 700.0, 0.0, -1.0, -3.0, "vicon", "base")
    robot = scale_translate(0.7, 0.7, 2.1, "base", "robot")
    text = dump_transforms({"base_to_robot": robot})
    added = load_transforms_text(set_transform(text, "vicon_to_base", new))
    assert added["base_to_robot"] == robot and added["vicon_to_base"].is_close(new)
    flow = "{base_to_robot: {source: base, target: robot, scale: 0.7}, " \
           "vicon_to_base: {source: vicon, target: base, scale: 2}}\n"
    rewritten = load_transforms_text(set_transform(flow, "vicon_to_base", new))
    assert rewritten["vicon_to_base"].is_close(new) and set(rewritten) == {
        "base_to_robot", "vicon_to_base"}


def load_transforms_text(text: str) -> dict:
    from fleet_common.frames import parse_transforms
    return parse_transforms(text)


# ---- the command ------------------------------------------------------------------------

@pytest.fixture
def frames_copy(tmp_path: Path) -> Path:
    path = tmp_path / "frames.yaml"
    shutil.copy(lab_frames_path(), path)
    return path


def test_calibrate_from_a_file_writes_the_fit(tmp_path: Path, frames_copy: Path) -> None:
    truth, pairs = truth_and_pairs(7, n=6)
    (tmp_path / "pairs.txt").write_text(format_correspondences(pairs))
    done = fleetctl("vicon", "calibrate", "--pairs", tmp_path / "pairs.txt", "--frames",
                    frames_copy)
    assert done.returncode == 0, done.stderr
    assert "RMS " in done.stdout and "wrote vicon_to_base into" in done.stdout
    assert all(p.label in done.stdout for p in pairs)
    written = load_transforms(frames_copy)
    assert written["base_to_robot"] == lab_transforms()["base_to_robot"]
    cells = np.array(LAB_CELLS, dtype=float)
    error = np.linalg.norm(written["vicon_to_base"].apply(truth.apply(cells)) - cells, axis=1)
    assert error.max() * 700 < 20.0  # within 2 cm everywhere


def test_calibrate_refuses_a_bad_fit_and_leaves_the_file(tmp_path: Path, frames_copy: Path) -> None:
    _, pairs = truth_and_pairs(8, n=6)
    pairs[2], pairs[3] = (Correspondence(pairs[3].cell, pairs[2].vicon, "swapped"),
                          Correspondence(pairs[2].cell, pairs[3].vicon, "swapped-too"))
    (tmp_path / "pairs.txt").write_text(format_correspondences(pairs))
    before = frames_copy.read_text()
    done = fleetctl("vicon", "calibrate", "--pairs", tmp_path / "pairs.txt", "--frames",
                    frames_copy)
    assert done.returncode == 1
    assert "refused: RMS" in done.stdout and "unchanged" in done.stdout
    assert frames_copy.read_text() == before


def test_calibrate_input_errors_are_one_line(tmp_path: Path, frames_copy: Path) -> None:
    (tmp_path / "three.txt").write_text("1 1 10 10\n2 1 20 10\n1 2 10 20\n")
    (tmp_path / "bad.txt").write_text("1 1 10 10\n1 1 x 10\n")
    (tmp_path / "same.txt").write_text("1 1 10 10\n2 1 20 10\n1 2 10 20\n1 1 30 30\n")
    (tmp_path / "big.txt").write_bytes(b"# " + b"x" * (1024 * 1024) + b"\n")
    (tmp_path / "binary.txt").write_bytes(b"1 1 10 10\n\xff\xfe\n")
    for name, fragment in (("three.txt", "three.txt: calibration needs at least 4"),
                           ("same.txt", "same.txt: target points 0 and 3 coincide"),
                           ("bad.txt", "bad.txt:2:5: bad vicon_x_mm 'x'"),
                           ("missing.txt", "missing.txt: cannot read"),
                           ("big.txt", "big.txt: larger than 1048576 bytes"),
                           ("binary.txt", "binary.txt: not UTF-8 text (byte 10)")):
        done = fleetctl("vicon", "calibrate", "--pairs", tmp_path / name, "--frames", frames_copy)
        assert done.returncode == 2 and fragment in done.stderr
        assert len(done.stderr.strip().splitlines()) == 1


def test_live_calibration_from_a_simulated_tracker(tmp_path: Path, frames_copy: Path) -> None:
    # the "real" lab: Vicon rotated and shifted against the nominal transform in frames.yaml
    real = tmp_path / "real.yaml"
    true_vicon = similarity(1 / 702.0, math.radians(3.0), -1.4, -2.6, "vicon", "base")
    real.write_text(set_transform(lab_frames_path().read_text(), "vicon_to_base", true_vicon))
    port = free_port()
    sim = subprocess.Popen([sys.executable, "-m", "fleetctl", "vicon", "simulate", "--demo",
                            "still", "--port", str(port), "--frames", str(real), "--noise", "3",
                            "--loss", "0.2", "--for", "30"], stdout=subprocess.PIPE, text=True)
    try:
        assert sim.stdout.readline().startswith("simulated Tracker: ")  # sending from now on
        done = fleetctl("vicon", "calibrate", "--live", "--port", port, "--bind", "127.0.0.1",
                        "--for", "1.5", "--frames", frames_copy, "--record",
                        tmp_path / "pairs.txt")
    finally:
        sim.terminate()
        sim.communicate(timeout=10)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count(" frames at (") == 5 and "recorded 5 pairs" in done.stdout
    assert len(parse_correspondences((tmp_path / "pairs.txt").read_text())) == 5
    fitted = load_transforms(frames_copy)["vicon_to_base"]
    cells = np.array(LAB_CELLS, dtype=float)
    seen = true_vicon.inverse().apply(cells)
    assert np.linalg.norm(fitted.apply(seen) - cells, axis=1).max() * 700 < 20.0
