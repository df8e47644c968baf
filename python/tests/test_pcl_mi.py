"""The Python module on real scans: accuracy, identity with the C++ API, reuse, bad input
and the GIL. Run by ctest (python_module) from the repository root."""
import os
import re
import subprocess
import tempfile
import threading
import time

import numpy as np
import pytest

import pcl_mi

DATA = os.path.join("data", "kitti")


def scan(sequence, frame):
    path = os.path.join(DATA, "sequences", sequence, "velodyne", f"{frame:06d}.bin")
    return np.fromfile(path, dtype=np.float32).reshape(-1, 4)


def reference(sequence, source, target):
    path = os.path.join(DATA, f"reference_{sequence}_{source:06d}_to_{target:06d}.txt")
    return np.loadtxt(path).reshape(4, 4)


def pose_error(estimate, truth):
    delta = np.linalg.inv(truth) @ estimate
    angle = np.degrees(np.arccos(np.clip((np.trace(delta[:3, :3]) - 1) / 2, -1, 1)))
    return np.linalg.norm(delta[:3, 3]), angle


@pytest.fixture(scope="module")
def pair():
    return scan("00", 9), scan("00", 0), reference("00", 9, 0)


def test_readme_example_runs():
    text = open("README.md").read()
    example = re.search(r"<!-- python-example:begin -->\s*```python\n(.*?)```", text, re.S)
    assert example, "README.md has no Python example"
    namespace = {}
    exec(compile(example.group(1), "README.md", "exec"), namespace)
    assert namespace["result"].converged


@pytest.mark.parametrize("sequence,source,target", [("00", 9, 0), ("02", 6, 0)])
def test_bundled_pairs_align_to_the_reference(sequence, source, target):
    result = pcl_mi.align(scan(sequence, source), scan(sequence, target))
    translation, rotation = pose_error(result.transformation, reference(sequence, source, target))
    assert result.converged
    assert translation < 0.08 and rotation < 0.2, (translation, rotation)
    assert result.transformation.shape == (4, 4) and result.transformation.dtype == np.float64
    assert result.evaluations > 0 and result.seconds > 0 and result.mutual_information > 0
    assert result.confidence >= 0.95 and result.reason == "" and result.refusal == "none"
    assert not result.reverse_confirmed
    assert result.covariance.shape == (6, 6) and np.all(np.diag(result.covariance) > 0)


def test_a_result_held_back_is_confirmed_by_the_clouds_swapped():
    # The first bundled Livox pair, source the earlier scan (list.txt: 288 onto 272).
    folder = os.path.join("data", "foreign_lidar", "livox_avia_hku1")
    load = lambda name: np.fromfile(os.path.join(folder, "scans", name),
                                    dtype=np.float32).reshape(-1, 4)
    row = open(os.path.join(folder, "list.txt")).readline().split()
    truth = np.linalg.inv(np.vstack([np.array(row[2:14], dtype=float).reshape(3, 4),
                                     [0, 0, 0, 1]]))
    result = pcl_mi.align(load("000272.bin"), load("000288.bin"))
    translation, rotation = pose_error(result.transformation, truth)
    assert result.converged and result.reverse_confirmed and result.reason == ""
    assert translation < 0.1 and rotation < 0.5, (translation, rotation)
    assert result.confidence >= 0.95 and np.all(np.diag(result.covariance) > 0)


def test_clouds_in_other_units_give_the_result_in_metres_with_the_units_set():
    # The same held-back pair at 1024 units a metre (a power of two scales exactly): with
    # units_per_metre the verdict, the confidence and the pose are those in metres.
    folder = os.path.join("data", "foreign_lidar", "livox_avia_hku1")
    load = lambda name: np.fromfile(os.path.join(folder, "scans", name),
                                    dtype=np.float32).reshape(-1, 4)
    source, target = load("000272.bin"), load("000288.bin")
    metres = pcl_mi.align(source, target)
    scaled = [np.hstack([cloud[:, :3] * np.float32(1024), cloud[:, 3:]])
              for cloud in (source, target)]
    units = pcl_mi.align(*scaled, units_per_metre=1024.0)
    assert units.converged == metres.converged
    assert units.reverse_confirmed == metres.reverse_confirmed
    assert units.confidence == pytest.approx(metres.confidence, abs=1e-9)
    pose = units.transformation.copy()
    pose[:3, 3] /= 1024.0
    assert np.allclose(pose, metres.transformation, rtol=0, atol=1e-9)


def test_an_unrelated_pair_is_not_trusted():
    result = pcl_mi.align(scan("02", 0), scan("00", 0))
    assert not result.converged and result.reason != ""
    assert result.refusal != "none"
    assert result.confidence < 0.5


def test_pose_is_bit_identical_to_the_cpp_api(pair):
    source, target, _ = pair
    result = pcl_mi.align(source, target)
    with tempfile.TemporaryDirectory() as work:
        transform = os.path.join(work, "t.txt")
        data = os.path.join(DATA, "sequences", "00", "velodyne")
        subprocess.run([os.environ["PCL_MI_ALIGN"], os.path.join(data, "000009.bin"),
                        os.path.join(data, "000000.bin"), "-no_output", "-transform", transform],
                       check=True, stdout=subprocess.DEVNULL)
        cpp = np.loadtxt(transform)  # written with 17 significant digits: exact
    # pcl_mi_align's PCL adapter is MutualInformationRegistration<PointXYZI>, whose final
    # transformation is a float 4x4: the engine's double pose rounded to float.
    assert np.array_equal(result.transformation.astype(np.float32).astype(np.float64), cpp)


def test_float64_input_and_extra_columns(pair):
    source, target, _ = pair
    a = pcl_mi.align(source[:, :3].astype(np.float64), target.astype(np.float64))
    b = pcl_mi.align(source, target)
    assert np.array_equal(a.transformation, b.transformation)


def test_scan_to_map_reuses_the_target():
    target = scan("00", 0)
    registration = pcl_mi.Registration()
    registration.set_target(target)
    first = registration.align(scan("00", 9))
    again = registration.align(scan("00", 9))
    fresh = pcl_mi.align(scan("00", 9), target)
    assert np.array_equal(first.transformation, again.transformation)
    assert np.array_equal(first.transformation, fresh.transformation)
    registration.set_source(scan("00", 9))
    assert registration.evaluate(first.transformation) == pytest.approx(
        first.mutual_information, rel=1e-12)


def test_resolution_is_derived_unless_set(pair):
    source, target, _ = pair
    assert pcl_mi.align(source, target).resolution == 1.0  # a street scan keeps 1 m
    assert pcl_mi.align(source, target, resolution=2.0).resolution == 2.0
    # The same scans in units of 1/8 m: the derived voxel follows the units.
    scaled = pcl_mi.align(source[:, :3] * 8, target[:, :3] * 8)
    assert scaled.resolution == 8.0


def test_parameters_by_name(pair):
    source, target, truth = pair
    result = pcl_mi.align(source, target, resolution=1.0, feature="count", pyramid_levels=3,
                          heading_starts=2, max_iterations=800)
    assert pose_error(result.transformation, truth)[0] < 0.08
    capped = pcl_mi.align(source, target, max_iterations=5)
    assert not capped.converged and capped.iterations <= 5
    guess = np.eye(4)
    guess[:3, 3] = truth[:3, 3] + [0.5, -0.5, 0.0]
    assert pcl_mi.align(source, target, guess=guess).converged


def test_a_tilted_sensor_is_leveled(pair):
    # The source as a sensor tilted by 25 deg of roll and -20 of pitch would have seen it.
    source, target, truth = pair
    roll, pitch = np.radians(25.0), np.radians(-20.0)
    rx = np.array([[1, 0, 0], [0, np.cos(roll), -np.sin(roll)], [0, np.sin(roll), np.cos(roll)]])
    ry = np.array([[np.cos(pitch), 0, np.sin(pitch)], [0, 1, 0], [-np.sin(pitch), 0, np.cos(pitch)]])
    turn = np.eye(4)
    turn[:3, :3] = ry @ rx
    tilted = source.copy()
    tilted[:, :3] = (source[:, :3].astype(np.float64) @ turn[:3, :3].T).astype(np.float32)
    result = pcl_mi.align(tilted, target)
    assert result.converged, result.reason
    assert pose_error(result.transformation, truth @ np.linalg.inv(turn))[0] < 0.08
    assert pcl_mi.align(source, target, leveling=False).converged


def test_the_coarsest_level_can_search_on_mi_alone(pair):
    # The paper's cost on every level, instead of normalised MI on the coarsest one.
    source, target, truth = pair
    result = pcl_mi.align(source, target, coarse_normalized_mi=False)
    assert result.converged, result.reason
    assert pose_error(result.transformation, truth)[0] < 0.08


@pytest.mark.parametrize("bad,reason", [
    (lambda s, t: pcl_mi.align(s[:, :2], t), "array"),
    (lambda s, t: pcl_mi.align(np.zeros((0, 3), np.float32), t), "no points"),
    (lambda s, t: pcl_mi.align(np.full((100, 3), np.nan, np.float32), t), "usable points"),
    (lambda s, t: pcl_mi.align(s.astype(np.int32), t), "float32 or float64"),
    (lambda s, t: pcl_mi.align(s, t, guess=np.full((4, 4), np.inf)), "finite"),
    (lambda s, t: pcl_mi.align(s, t, guess=np.eye(3)), "4x4"),
    (lambda s, t: pcl_mi.align(s, t, resolution=-1.0), "resolution"),
    (lambda s, t: pcl_mi.align(s, t, feature="colour"), "feature"),
    (lambda s, t: pcl_mi.align(s, t, max_iterations=0), "maximum iterations"),
    (lambda s, t: pcl_mi.align(s, t, backend="gpu"), "backend"),
    (lambda s, t: pcl_mi.align(s, t, batching="yes"), "batching"),
    (lambda s, t: pcl_mi.align(s, t, narrow_view_yaw_start=4.0), "narrow-view yaw start"),
    (lambda s, t: pcl_mi.align(s, t, narrow_view_scanned_starts=9), "narrow-view scanned starts"),
    (lambda s, t: pcl_mi.align(s, t, refinement_narrow_view_stages=5),
     "narrow-view refinement stages"),
    (lambda s, t: pcl_mi.align(s, t, units_per_metre=0.0), "units per metre"),
])
def test_bad_input_raises_value_error_with_the_reason(pair, bad, reason):
    source, target, _ = pair
    with pytest.raises(ValueError, match=reason):
        bad(source, target)


def test_unknown_parameter_is_a_type_error(pair):
    source, target, _ = pair
    with pytest.raises(TypeError, match="resoluton"):
        pcl_mi.align(source, target, resoluton=0.5)


def test_the_gil_is_released_while_aligning(pair):
    """Two threads align at once: their align() calls overlap in time only if the first
    released the GIL."""
    source, target, _ = pair
    registrations = [pcl_mi.Registration(num_threads=1) for _ in range(2)]
    for r in registrations:
        r.set_target(target)
    barrier = threading.Barrier(2)
    spans = [None, None]
    results = [None, None]

    def work(k):
        barrier.wait()
        begin = time.monotonic()
        results[k] = registrations[k].align(source)
        spans[k] = (begin, time.monotonic())

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    (a0, a1), (b0, b1) = spans
    assert max(a0, b0) < min(a1, b1), spans  # the calls ran at the same time
    assert np.array_equal(results[0].transformation, results[1].transformation)
