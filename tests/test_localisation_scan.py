"""The paper's scan processing (localisation.scan) and the raw-vs-processed comparison."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation.scan import ScanProcessing, min_reading, process_scan, raw_scan, window_mask
from localisation.scan_benchmark import compare_scan_processing
from toolkit.world import NO_ECHO, Scan, default_scan_angles, load_map


def _scan(ranges: np.ndarray) -> Scan:
    return Scan.from_readings(default_scan_angles(), ranges)


def test_paper_windows_keep_124_of_360() -> None:
    ps = process_scan(_scan(np.full(360, 40.0)))
    assert len(ps) == 124  # 4 windows of 31 one-degree readings
    kept_deg = np.rint(np.degrees(ps.scan.angles)).astype(int) % 360
    for centre in (0, 90, 180, 270):
        off = np.abs(((kept_deg - centre) + 180) % 360 - 180)
        assert np.count_nonzero(off <= 15) == 31
    assert ps.in_window == 124 and ps.dropped_invalid == 0


def test_no_echo_and_out_of_range_are_dropped() -> None:
    r = np.full(360, 40.0)
    r[0] = NO_ECHO  # in a window, no echo
    r[5] = np.inf  # in a window, simulator's no hit
    r[10] = 3.0  # in a window, below min range
    r[45] = NO_ECHO  # outside the windows
    ps = process_scan(_scan(r), ScanProcessing(min_range_cm=6.0))
    assert len(ps) == 121
    assert ps.dropped_invalid == 2 and ps.dropped_range == 1
    # the windows' no-echo readings travel on, marked invalid, for localisers that model silence
    heard, silent = ps.scan.valid, ~ps.scan.valid
    assert heard.sum() == 121 and np.all(ps.scan.ranges[heard] < NO_ECHO)
    assert sorted(ps.scan.ranges[silent].tolist()) == [NO_ECHO, np.inf]


def test_window_and_centres_configurable() -> None:
    ps = process_scan(_scan(np.full(360, 40.0)), centres_deg=(0.0, 180.0), window_deg=5.0)
    assert len(ps) == 22


def test_min_reading_is_middle_of_flat_run() -> None:
    r = np.full(360, 80.0)
    r[20:31] = 30.0  # a wide lobe reads the wall's perpendicular distance over 11 degrees
    angle, value = min_reading(_scan(r))
    assert value == 30.0
    assert math.degrees(angle) == pytest.approx(25.0)
    r[358] = 29.5  # a single minimum across the wrap-around
    angle, _ = min_reading(_scan(r), tolerance_cm=0.1)
    assert math.degrees(angle) == pytest.approx(-2.0)


def test_min_reading_ignores_invalid_and_reference_min_recentres() -> None:
    r = np.full(360, 80.0)
    r[100] = NO_ECHO
    r[200] = 20.0
    angle, value = min_reading(_scan(r))
    assert value == 20.0 and math.degrees(angle) == pytest.approx(-160.0)
    ps = process_scan(_scan(r), reference="min")
    assert math.degrees(ps.reference_rad) == pytest.approx(-160.0)
    assert window_mask(np.radians([200.0]), ps.reference_rad)[0]


def test_raw_scan_keeps_all_usable() -> None:
    r = np.full(360, 40.0)
    r[:10] = NO_ECHO
    assert len(raw_scan(_scan(r))) == 350


def test_processing_reduces_nxt_reading_errors() -> None:
    # the paper's claim at the level of the readings: near-perpendicular readings are more accurate
    cmp = compare_scan_processing(load_map("map1"), n_poses=12, rng=3, localise=False)
    assert cmp.processed.readings.median_abs_error_cm < cmp.raw.readings.median_abs_error_cm
    assert cmp.processed.readings.gross_fraction < cmp.raw.readings.gross_fraction
    assert cmp.to_dict()["raw"]["n_poses"] == 12
    assert "processed" in cmp.summary()


def test_free_travel_of_the_robot_disc() -> None:
    from localisation.exploration import free_travel

    # a wall 20 cm ahead (x = 20) seen by every forward reading, nothing else
    a = default_scan_angles()
    r = np.where(np.cos(a) > 0.05, 20.0 / np.maximum(np.cos(a), 1e-9), np.inf)
    scan = Scan.from_readings(a, r)
    _phi, free = free_travel(scan, 8.0, np.radians([0.0, 60.0, 180.0]))
    assert free[0] == pytest.approx(12.0, abs=0.05)  # the disc touches the wall after 20 - 8 cm
    assert free[1] == pytest.approx(20.0 / math.cos(math.radians(60.0)) - 8.0 / math.cos(math.radians(60.0)), abs=1.0)
    assert math.isinf(free[2])
