"""The simulated curved/direct scenario: determinism, format, shapes of the movements, the head."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from promp.data import Demonstration
from promp.datasets import load_csv_dataset, read_csv_demo
from robots.icub.gaze import head_angles_following, landmark_gaze
from robots.icub.ik import solve_ik
from robots.icub.kinematics import load_arm
from robots.icub.motion import arc_progress, minimum_jerk, smooth_path
from robots.icub.scenario import (
    COLUMNS,
    PRIMITIVES,
    THIRD_PRIMITIVE,
    ScenarioParams,
    generate_demonstration,
    generate_scenario,
    main,
)
from robots.icub.scene import (
    DEFAULT_SCENE,
    PARTNER_HEAD,
    ROBOT_EYES,
    head_orientation_looking_at,
)
from tests.conftest import REPO

QUIET = ScenarioParams(
    head_noise_deg=0.0, head_drift_deg=0.0, roll_bias_deg=0.0, head_position_jitter=0.0
)


@pytest.fixture(scope="module")
def dataset() -> dict[str, list[Demonstration]]:
    return generate_scenario(seed=0, n_demos=20, third=True)


def _at_phase(demos: list[Demonstration], phase: float, columns: slice) -> np.ndarray:
    """Values at a normalised phase in [0, 1], one row per demonstration."""
    rows = []
    for demo in demos:
        t = demo.times[0] + phase * demo.duration
        rows.append([np.interp(t, demo.times, demo.values[:, k]) for k in range(6)])
    return np.array(rows)[:, columns]


def test_primitives_counts_columns_and_rate(dataset: dict[str, list[Demonstration]]) -> None:
    assert list(dataset) == [*PRIMITIVES, THIRD_PRIMITIVE]
    for primitive, demos in dataset.items():
        assert len(demos) == 20
        assert len({d.name for d in demos}) == 20
        for demo in demos:
            assert demo.columns == COLUMNS
            assert demo.name.startswith(f"{primitive}_")
            assert demo.times[0] == 0.0
            assert_allclose(np.diff(demo.times), 1 / 40.0, rtol=1e-9)
            assert np.all(np.isfinite(demo.values))


def test_same_seed_same_data_other_seed_other_data() -> None:
    a = generate_scenario(seed=7, n_demos=3)
    b = generate_scenario(seed=7, n_demos=3)
    c = generate_scenario(seed=8, n_demos=3)
    assert list(a) == list(PRIMITIVES)
    for primitive in a:
        for x, y, z in zip(a[primitive], b[primitive], c[primitive], strict=True):
            assert_allclose(x.times, y.times, atol=0)
            assert_allclose(x.values, y.values, atol=0)
            assert x.values.shape != z.values.shape or not np.allclose(x.values, z.values)


def test_the_third_primitive_does_not_change_the_others(
    dataset: dict[str, list[Demonstration]],
) -> None:
    two = generate_scenario(seed=0, n_demos=2, third=False)
    for primitive in PRIMITIVES:
        for demo, other in zip(two[primitive], dataset[primitive][:2], strict=True):
            assert_allclose(demo.values, other.values, atol=0)


def test_curved_and_direct_share_start_and_end_but_not_the_middle(
    dataset: dict[str, list[Demonstration]],
) -> None:
    hand = slice(0, 3)
    pick = np.array(DEFAULT_SCENE.pick_position)
    drop = DEFAULT_SCENE.bins[0].drop_position
    for primitive in PRIMITIVES:
        starts = _at_phase(dataset[primitive], 0.0, hand)
        ends = _at_phase(dataset[primitive], 1.0, hand)
        assert np.linalg.norm(starts - pick, axis=1).max() < 0.02
        assert np.linalg.norm(ends - drop, axis=1).max() < 0.02
    for phase in (0.0, 1.0):
        curved = _at_phase(dataset["curved"], phase, hand).mean(axis=0)
        direct = _at_phase(dataset["direct"], phase, hand).mean(axis=0)
        assert np.linalg.norm(curved - direct) < 0.01
    for phase in (0.6, 0.7):
        curved = _at_phase(dataset["curved"], phase, hand)
        direct = _at_phase(dataset["direct"], phase, hand)
        assert np.linalg.norm(curved.mean(axis=0) - direct.mean(axis=0)) > 0.12
        assert curved[:, 2].min() > direct[:, 2].max() + 0.08, "the curved movement arches up"
    # All begin by lifting the object: the first 35 % of the movement goes mostly up.
    for primitive in dataset:
        early = _at_phase(dataset[primitive], 0.35, hand) - _at_phase(dataset[primitive], 0.0, hand)
        assert np.all(early[:, 2] > 0.04)
        assert np.all(early[:, 2] > 5 * np.linalg.norm(early[:, :2], axis=1))
    # The third primitive ends at the other bin.
    ends = _at_phase(dataset[THIRD_PRIMITIVE], 1.0, hand)
    assert np.linalg.norm(ends - DEFAULT_SCENE.bins[1].drop_position, axis=1).max() < 0.02


def test_curved_and_direct_hands_coincide_for_the_first_40_percent_then_part(
    dataset: dict[str, list[Demonstration]],
) -> None:
    # Early hand observations are ambiguous: the same lift with the same timing, up to the
    # per-demonstration jitter (same mean, same spread) ...
    hand = slice(0, 3)
    for phase in np.arange(0.0, 0.401, 0.05):
        curved = _at_phase(dataset["curved"], phase, hand)
        direct = _at_phase(dataset["direct"], phase, hand)
        assert np.linalg.norm(curved.mean(axis=0) - direct.mean(axis=0)) < 0.005, phase
        assert_allclose(curved.std(axis=0), direct.std(axis=0), atol=0.003)
    # ... then they part: several centimetres at half the movement, far apart after.
    curved = _at_phase(dataset["curved"], 0.5, hand)
    direct = _at_phase(dataset["direct"], 0.5, hand)
    assert np.linalg.norm(curved.mean(axis=0) - direct.mean(axis=0)) > 0.04
    for phase in (0.6, 0.7):
        curved = _at_phase(dataset["curved"], phase, hand)
        direct = _at_phase(dataset["direct"], phase, hand)
        assert np.linalg.norm(curved[:, None] - direct[None], axis=-1).min() > 0.1


def test_without_jitter_curved_and_direct_share_path_and_timing_up_to_40_percent() -> None:
    exact = replace(QUIET, via_jitter=0.0, end_jitter=0.0, duration_spread=0.0)
    arm = load_arm()
    curved, direct = (
        generate_demonstration(arm, DEFAULT_SCENE, p, np.random.default_rng(5), 40.0, exact)
        for p in PRIMITIVES
    )
    assert_allclose(curved.times, direct.times, atol=0)
    distance = np.linalg.norm(curved.values[:, :3] - direct.values[:, :3], axis=1)
    phase = curved.times / curved.times[-1]
    assert distance[phase <= 0.4].max() < 1e-5  # 10 um: the IK's and the arc tables' precision
    assert distance[np.argmin(np.abs(phase - 0.5))] > 0.04
    assert distance[-1] < 1e-5


def test_the_head_tells_curved_from_direct_while_the_hands_coincide(
    dataset: dict[str, list[Demonstration]],
) -> None:
    def gap_and_spread(phase: float) -> tuple[float, float]:
        curved = np.rad2deg(_at_phase(dataset["curved"], phase, slice(4, 6)))
        direct = np.rad2deg(_at_phase(dataset["direct"], phase, slice(4, 6)))
        gap = float(np.linalg.norm(curved.mean(axis=0) - direct.mean(axis=0)))
        spread = max(
            float(np.sqrt(((a - a.mean(axis=0)) ** 2).sum(axis=1).mean())) for a in (curved, direct)
        )
        return gap, spread

    # Both watch the object until it leaves the table ...
    for phase in (0.0, 0.05):
        gap, spread = gap_and_spread(phase)
        assert gap < 3.0
    # ... then look where the hand is going: the apex, well above the bin as seen from the
    # partner, or the bin. The difference in (pitch, yaw) dwarfs the spread between
    # demonstrations (noise, drift, head position, timing) well before the hands part.
    gap, spread = gap_and_spread(0.15)
    assert gap > spread
    for phase in np.arange(0.2, 0.451, 0.05):
        gap, spread = gap_and_spread(phase)
        assert gap > 10.0 and gap > 2.5 * spread, (phase, gap, spread)


def test_timing_path_and_gaze_building_blocks() -> None:
    # The detour's extra submovement leaves the direct timing untouched until it starts.
    tau = np.linspace(0.0, 1.0, 401)
    direct = arc_progress(tau, 0.3, 0.3, 0.45)
    assert_allclose(direct, 0.3 * minimum_jerk(tau))
    curved = arc_progress(tau, 0.6, 0.3, 0.45)
    assert_allclose(curved[tau <= 0.45], direct[tau <= 0.45], atol=0)
    assert curved[-1] == pytest.approx(0.6) and np.all(np.diff(curved) >= 0.0)
    assert np.diff(curved)[[0, -1]].max() < 1e-6, "starts and ends at rest"
    with pytest.raises(ValueError, match="moving backwards"):
        arc_progress(tau, 0.1, 0.3, 0.45)
    # Paths through the same first via points share their first pieces exactly.
    pick, lift = np.array([-0.27, -0.1, 0.01]), np.array([-0.27, -0.1, 0.12])
    apex, drop = np.array([-0.25, -0.13, 0.33]), np.array([-0.24, -0.29, 0.1])
    with_apex = smooth_path(np.array([pick, lift, apex, drop]))
    without = smooth_path(np.array([pick, lift, drop]))
    assert_allclose(with_apex.knot_arc[:2], without.knot_arc[:2])
    s = np.linspace(0.0, with_apex.knot_arc[1], 50)
    assert_allclose(with_apex.at(s), without.at(s), atol=1e-12)
    assert_allclose(with_apex.at(with_apex.knot_arc), [pick, lift, apex, drop], atol=1e-6)
    # The gaze: object until the shift, apex until `lead` before the hand gets there, then drop.
    landmarks = np.array([pick, apex, drop])
    times = np.arange(7) * 0.5
    gaze = landmark_gaze(times, landmarks, np.array([0.0, 2.0, 3.0]), shift=0.6, lead=0.5)
    assert_allclose(gaze, landmarks[[0, 0, 1, 2, 2, 2, 2]])
    # Too late to look at the apex: straight to the drop point.
    gaze = landmark_gaze(times, landmarks, np.array([0.0, 1.0, 3.0]), shift=0.6, lead=0.5)
    assert_allclose(gaze, landmarks[[0, 0, 2, 2, 2, 2, 2]])


def test_durations_vary_about_three_seconds(dataset: dict[str, list[Demonstration]]) -> None:
    for demos in dataset.values():
        durations = np.array([d.duration for d in demos])
        assert np.all((durations >= 0.7 * 3.0 - 0.03) & (durations <= 1.3 * 3.0 + 0.03))
        assert durations.std() / durations.mean() > 0.08
        assert 2.6 < durations.mean() < 3.4


def test_minimum_jerk_timing(dataset: dict[str, list[Demonstration]]) -> None:
    assert_allclose(minimum_jerk(np.array([0.0, 0.5, 1.0])), [0.0, 0.5, 1.0])
    for demo in dataset["direct"][:5]:
        hand = demo.values[:, :3]
        speed = np.linalg.norm(np.diff(hand, axis=0), axis=1) / np.diff(demo.times)
        # Starts and ends at rest, fastest in the middle.
        assert speed[0] < 0.02 and speed[-1] < 0.02
        peak = np.argmax(speed) / len(speed)
        assert 0.25 < peak < 0.75


def test_every_hand_sample_is_reachable_with_the_torso_locked(
    dataset: dict[str, list[Demonstration]],
) -> None:
    arm = load_arm()
    for primitive in dataset:
        demo = dataset[primitive][0]
        q = arm.rest
        for target in demo.values[::4, :3]:
            result = solve_ik(arm, target, q, lock_torso=True)
            assert result.position_error_m < 1e-4
            q = result.q


def _half_change_time(times: np.ndarray, values: np.ndarray) -> float:
    change = values[-1] - values[0]
    progress = (values - values[0]) / change
    return float(times[np.argmax(progress >= 0.5)])


def _smooth(values: np.ndarray, width: int = 9) -> np.ndarray:
    padded = np.pad(values, width // 2, mode="edge")
    return np.convolve(padded, np.ones(width) / width, mode="valid")


def _looking_at_deg(head: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Largest of the pitch and yaw differences between ``head`` (n, 3) or (3,) and looking at
    ``points`` (n, 3) or (3,) from the default partner, degrees."""
    _, pitch, yaw = head_orientation_looking_at(points, PARTNER_HEAD)
    looking = np.stack([np.asarray(pitch), np.asarray(yaw)], axis=-1)
    return np.rad2deg(np.abs(np.asarray(head)[..., 1:] - looking).max(axis=-1))


def test_the_head_leads_the_hand_without_noise() -> None:
    # The gaze goes from landmark to landmark ahead of the hand: the object, then (curved) the
    # apex, then the drop point; the head follows it.
    arm = load_arm()
    rng = np.random.default_rng(30)
    for primitive in ("direct", "second_bin", "curved"):
        for _ in range(3):
            demo = generate_demonstration(arm, DEFAULT_SCENE, primitive, rng, 40.0, QUIET)
            hand, head, times = demo.values[:, :3], demo.values[:, 3:], demo.times
            assert_allclose(head[:, 0], 0.0, atol=0)
            # At the start the partner looks at the object, in the hand.
            assert _looking_at_deg(head[0], hand[0]) < 0.1
            # At 35 % of the movement, while the hand is still lifting, the head already points
            # at where the hand goes next: the drop point, or the curved movement's apex, which
            # the hand reaches only after 55 % of the movement.
            k = int(0.35 * (len(times) - 1))
            assert hand[k, 2] - hand[0, 2] < 0.09
            fine = np.linspace(0.0, times[-1], 20 * len(times))
            path = np.column_stack([np.interp(fine, times, hand[:, j]) for j in range(3)])
            errors = _looking_at_deg(np.tile(head[k], (len(fine), 1)), path)
            assert errors.min() < 1.5, primitive
            if primitive == "curved":
                assert fine[np.argmin(errors)] > 0.55 * times[-1]
            else:
                assert errors[-1] < 1.5
            # And it stays on the drop point for the end of the movement.
            assert _looking_at_deg(head[-1], hand[-1]) < 0.5
            _, pitch, yaw = head_orientation_looking_at(hand, PARTNER_HEAD)
            if primitive == "curved":
                # The head leaves the apex for the drop point just before the hand gets there.
                top = times[np.argmin(pitch)]
                leaves = times[np.nonzero(head[:, 1] < head[:, 1].min() + np.deg2rad(0.5))[0][-1]]
                lead = top - leaves
                assert 0.05 < lead < 0.5, f"{primitive}: head leaves the apex {lead:.2f} s ahead"
            else:
                lead = _half_change_time(times, yaw) - _half_change_time(times, head[:, 2])
                assert 0.5 < lead < 2.0, f"{primitive}: head turns {lead:.2f} s ahead"


def test_the_head_leads_the_hand_through_the_noise(
    dataset: dict[str, list[Demonstration]],
) -> None:
    leads = []
    for primitive in ("direct", THIRD_PRIMITIVE):
        for demo in dataset[primitive]:
            _, _, yaw = head_orientation_looking_at(demo.values[:, :3], PARTNER_HEAD)
            head_yaw = _smooth(demo.values[:, 5])
            leads.append(
                _half_change_time(demo.times, yaw) - _half_change_time(demo.times, head_yaw)
            )
    assert np.mean(leads) > 0.25
    assert np.mean(np.array(leads) > 0) > 0.8


def test_head_angles_are_relative_to_looking_at_the_robot_from_the_offset_head() -> None:
    times = np.arange(41) / 40.0
    rng = np.random.default_rng(31)
    for head in (np.array(PARTNER_HEAD), np.array(PARTNER_HEAD) + [0.03, -0.04, 0.05]):
        # Watching the robot's eyes is zero, from wherever the head is.
        at_eyes = head_angles_following(times, np.tile(ROBOT_EYES, (41, 1)), head, rng, QUIET)
        assert_allclose(at_eyes, 0.0, atol=1e-12)
        # Watching a still point: the angles of looking at it from that head.
        point = np.array([-0.3, -0.2, 0.05])
        still = head_angles_following(times, np.tile(point, (41, 1)), head, rng, QUIET)
        assert_allclose(still, np.tile(head_orientation_looking_at(point, head), (41, 1)))
    other = head_orientation_looking_at(point, PARTNER_HEAD)
    assert np.abs(np.subtract(other, still[0])).max() > np.deg2rad(0.5)


def test_the_partner_looks_down_at_the_hand_below_the_robot_eyes(
    dataset: dict[str, list[Demonstration]],
) -> None:
    # Zero is looking at the robot's eyes; the hand works on the table below them, so the head
    # pitches down (positive) by about 5-25 deg, and turns towards the partner's right (negative
    # yaw) for the first bin, on the robot's left. The curved movement's apex is about as high
    # as the robot's eyes: the head rises to it.
    for primitive, demos in dataset.items():
        head = np.concatenate([d.values[:, 3:] for d in demos])
        assert np.abs(head[:, 2]).max() < np.deg2rad(35.0), primitive
        assert np.abs(np.median(head[:, 0])) < np.deg2rad(2.0), primitive
        start = _at_phase(demos, 0.0, slice(4, 6)).mean(axis=0)
        assert np.deg2rad(15.0) < start[0] < np.deg2rad(25.0), "the object, down on the table"
        end = _at_phase(demos, 1.0, slice(4, 6)).mean(axis=0)
        assert np.deg2rad(8.0) < end[0] < np.deg2rad(18.0), "the bin, down on the table"
        if primitive == "curved":
            continue
        assert np.deg2rad(8.0) < np.median(head[:, 1]) < np.deg2rad(18.0), primitive
        assert np.mean(head[:, 1] > 0.0) > 0.95, primitive
    apex = _at_phase(dataset["curved"], 0.4, slice(4, 5))
    assert abs(np.median(apex)) < np.deg2rad(5.0)
    for primitive in PRIMITIVES:
        assert _at_phase(dataset[primitive], 1.0, slice(5, 6)).mean() < np.deg2rad(-12.0)
    assert abs(_at_phase(dataset[THIRD_PRIMITIVE], 1.0, slice(5, 6)).mean()) < np.deg2rad(6.0)


def test_head_noise_is_webcam_like(dataset: dict[str, list[Demonstration]]) -> None:
    # Sample-to-sample jitter of a few degrees, not more.
    jumps = np.concatenate([np.diff(d.values[:, 3:], axis=0) for d in dataset["direct"]])
    jitter_deg = np.rad2deg(jumps.std(axis=0)) / np.sqrt(2)
    assert np.all((jitter_deg > 1.0) & (jitter_deg < 4.0))
    # The curved movement makes the head rise more (smaller pitch) in the middle.
    mid_pitch = {p: _at_phase(dataset[p], 0.45, slice(4, 5)).mean() for p in PRIMITIVES}
    assert mid_pitch["curved"] < mid_pitch["direct"] - np.deg2rad(8.0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"seed": -1}, "seed must be >= 0"),
        ({"seed": 1.5}, "seed must be an integer"),
        ({"seed": True}, "seed must be an integer"),
        ({"n_demos": 1}, "n_demos must be between 2 and 1000"),
        ({"n_demos": 1001}, "n_demos must be between 2 and 1000"),
        ({"rate_hz": 29.0}, "rate_hz must be between 30 and 50"),
        ({"rate_hz": 51.0}, "rate_hz must be between 30 and 50"),
        ({"rate_hz": float("nan")}, "rate_hz must be between 30 and 50"),
        ({"robot": "iCubNowhere"}, "unknown robot 'iCubNowhere'"),
        ({"robot": "left_hand_mk3"}, "no tip link 'l_hand_dh_frame'"),
    ],
)
def test_bad_arguments_are_clear_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        generate_scenario(**{"n_demos": 2, **kwargs})


def test_other_rates_are_honoured() -> None:
    data = generate_scenario(seed=3, n_demos=2, rate_hz=30.0)
    for demos in data.values():
        for demo in demos:
            assert_allclose(np.diff(demo.times), 1 / 30.0, rtol=1e-9)


def test_command_line_writes_the_csv_folder_format(tmp_path: Path) -> None:
    out = tmp_path / "scenario"
    proc = subprocess.run(
        [sys.executable, "-m", "robots.icub.scenario", str(out), "--demos", "2", "--seed", "4"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "wrote 4 demonstrations" in proc.stdout
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*.csv"))
    assert files == ["curved/curved_000.csv", "curved/curved_001.csv",
                     "direct/direct_000.csv", "direct/direct_001.csv"]  # fmt: skip
    header = (out / "curved" / "curved_000.csv").read_text().splitlines()[0]
    assert header == "t,x,y,z,roll,pitch,yaw"
    loaded = load_csv_dataset(out)
    expected = generate_scenario(seed=4, n_demos=2)
    for primitive, demos in expected.items():
        for demo, back in zip(demos, loaded[primitive], strict=True):
            assert back.columns == COLUMNS
            assert_allclose(back.times, demo.times, atol=0)
            assert_allclose(back.values, demo.values, atol=0)


def test_command_line_third_and_rate(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main([str(tmp_path / "d"), "--demos", "2", "--third", "--rate", "50"]) == 0
    assert sorted(p.name for p in (tmp_path / "d").iterdir()) == sorted(
        [*PRIMITIVES, THIRD_PRIMITIVE]
    )
    demo = read_csv_demo(tmp_path / "d" / THIRD_PRIMITIVE / f"{THIRD_PRIMITIVE}_001.csv")
    assert_allclose(np.diff(demo.times), 0.02, rtol=1e-9)
    assert "at 50 Hz" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args, message",
    [
        (["--demos", "1"], "n_demos must be between 2 and 1000"),
        (["--seed", "-3"], "seed must be >= 0"),
        (["--rate", "60"], "rate_hz must be between 30 and 50"),
        (["--robot", "iCubNowhere"], "unknown robot 'iCubNowhere'"),
    ],
)
def test_command_line_bad_input_exits_non_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture, args: list[str], message: str
) -> None:
    assert main([str(tmp_path / "out"), *args]) != 0
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err
    assert not (tmp_path / "out").exists()


def test_command_line_refuses_a_non_empty_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    assert main([str(tmp_path), "--demos", "2"]) != 0
    assert "not empty" in capsys.readouterr().err
    assert main([str(tmp_path), "--demos", "2", "--force"]) == 0
    assert (tmp_path / "keep.txt").read_text() == "mine"
    assert len(list(tmp_path.rglob("*.csv"))) == 4


def test_command_line_usage_errors_exit_non_zero() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "robots.icub.scenario", "/tmp/x", "--demos", "many"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode != 0 and "--demos" in proc.stderr


def test_scenes_and_parameters_that_cannot_work_are_clear_errors() -> None:
    one_bin = replace(DEFAULT_SCENE, bins=DEFAULT_SCENE.bins[:1])
    assert list(generate_scenario(n_demos=2, scene=one_bin)) == list(PRIMITIVES)
    with pytest.raises(ValueError, match="1 bin.*2 needed for the third primitive"):
        generate_scenario(n_demos=2, third=True, scene=one_bin)
    far = replace(DEFAULT_SCENE, pick_position=(-0.9, -0.1, 0.01))
    with pytest.raises(ValueError, match="leaves the left arm's reach"):
        generate_scenario(n_demos=2, scene=far)
    with pytest.raises(ValueError, match="head_noise_deg"):
        ScenarioParams(head_noise_deg=-1.0)
    with pytest.raises(ValueError, match="gaze_lead"):
        ScenarioParams(gaze_lead=(1.0, 0.5))
    with pytest.raises(ValueError, match="duration_spread"):
        ScenarioParams(duration_spread=1.0)
    with pytest.raises(ValueError, match="shared_fraction"):
        ScenarioParams(shared_fraction=1.0)
    with pytest.raises(ValueError, match="lift > 0"):
        ScenarioParams(lift=0.0)
    with pytest.raises(ValueError, match="gaze_latency"):
        ScenarioParams(gaze_latency=(0.2, 0.1))


def test_unknown_primitive_is_a_clear_error() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="unknown primitive 'wiggle'"):
        generate_demonstration(load_arm(), DEFAULT_SCENE, "wiggle", rng)
