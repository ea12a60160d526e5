"""Section V's long-run measures on synthetic profiles with known answers."""
import numpy as np
import pytest

from compare.sectionv import (band_speed, contrast, end_species, exchange, interface_width, interfaces,
                              band_onsets, lasting_below, pattern_excursion)

Y = np.arange(-63.5, 64.0, 1.0)  # 128 slice centres of a drum of L = 128


def two_halves(b=0.0, width=0.0):
    """Big (0) below y = b, small (1) above, over a linear ramp ``width`` long."""
    phi = np.clip((Y - b) / width + 0.5, 0, 1) if width > 0 else (Y >= b).astype(float)
    return phi


def test_interface_width_sharp_and_ramped():
    assert interface_width(two_halves(0.0), 1.0, 1) == 0.0
    w = interface_width(two_halves(0.0, width=20.0), 1.0, 1)
    assert 15 <= w <= 17  # 0.1 < phi < 0.9 over 80 % of the 20-slice ramp
    mixed = np.full_like(Y, 0.5)
    assert interface_width(mixed, 1.0, 2) == pytest.approx(64.0)


def test_lasting_below():
    t = np.arange(10.0)
    assert lasting_below(t, [5, 5, 2, 5, 2, 2, 2, 2, 2, 2], 3) == 4.0
    assert lasting_below(t, [5] * 10, 3) is None
    assert lasting_below(t, [1] * 10, 3) == 0.0


def test_exchange_sign():
    a, b = two_halves(0.0, 4.0), 1 - two_halves(0.0, 4.0)
    ex = exchange(np.array([a, a, np.full_like(Y, 0.5), b]), 0.5)
    assert ex[0] == pytest.approx(1.0) and ex[1] == pytest.approx(1.0)
    assert ex[2] == pytest.approx(0.0) and ex[3] == pytest.approx(-1.0)


def test_interfaces_and_band_speed():
    """A boundary moving at 0.01 per rotation over 4000 rotations: the speed
    is found to within 10 %; a standing one gives zero."""
    t = np.arange(0.0, 4000.0, 2.0)
    phi = np.array([two_halves(-10.0 + 0.01 * tt, 6.0) for tt in t])
    assert interfaces(phi[0], Y, 0.5) == pytest.approx([-10.0], abs=0.1)
    speed, slopes = band_speed(t, Y, phi, 0.5, window=1000.0)
    assert speed == pytest.approx(0.01, rel=0.1) and len(slopes) >= 1
    still = np.array([two_halves(5.0, 6.0) for _ in t])
    assert band_speed(t, Y, still, 0.5, window=1000.0)[0] == pytest.approx(0.0, abs=1e-9)


def test_end_species_and_contrast():
    # big (phi = 0) at both ends, small in the middle
    phi = np.where(np.abs(Y) < 30, 1.0, 0.0)
    assert end_species(phi, 0.5) == ("big", "big")
    assert end_species(1 - phi, 0.5) == ("small", "small")
    # the slice against each cap holds the grains that fit closest to it, small ones: not the end band
    capped = phi.copy()
    capped[0] = capped[-1] = 1.0
    assert end_species(capped, 0.5) == ("big", "big")
    assert contrast(np.full_like(Y, 0.5), 0.5) == pytest.approx(0.0)
    assert contrast(phi, 0.5, smoothing=0.5) > 0.45


def test_pattern_excursion_follows_the_dominant_mode():
    """Six bands (k = 3) swinging by +-5 slices: excursion 10, wavelength
    128/3; a merge to four bands (k = 2) partway restarts the stretch, and a
    stretch shorter than the minimum gives None."""
    t = np.arange(0.0, 1000.0, 1.0)
    six = lambda x0: 0.5 + 0.4 * np.cos(2 * np.pi * 3 * (Y - x0) / 128.0)
    four = lambda x0: 0.5 + 0.4 * np.cos(2 * np.pi * 2 * (Y - x0) / 128.0)
    phi = np.array([six(5.0 * np.sin(2 * np.pi * tt / 300.0)) for tt in t])
    exc, lam, rot = pattern_excursion(t, phi, 0.5, 128.0)
    assert exc == pytest.approx(10.0, abs=0.05) and lam == pytest.approx(128 / 3) and rot == pytest.approx(999.0)
    # a steady drift of 30 slices, more than one wavelength/2: unwrapped, not folded back
    drift = np.array([six(0.03 * tt) for tt in t])
    assert pattern_excursion(t, drift, 0.5, 128.0)[0] == pytest.approx(0.03 * 999, rel=1e-3)
    merged = np.array([six(0.0) if tt < 600 else four(2.0 + 0.01 * tt) for tt in t])
    exc, lam, rot = pattern_excursion(t, merged, 0.5, 128.0)
    assert lam == pytest.approx(64.0) and rot == pytest.approx(399.0) and exc == pytest.approx(0.01 * 399, rel=1e-3)
    assert pattern_excursion(t, merged, 0.5, 128.0, min_rotations=500.0) is None


def test_band_onsets_find_where_formation_starts():
    """A capped drum of five bands: big at both ends (from rotation 40), three
    interior bands growing from rotations 10, 12 and 20 (amplitude 0.02 a
    rotation past their start), and the slice against each cap full of small
    grains from the start, which must not count as an early end band."""
    t = np.arange(0.0, 100.0, 0.25)
    edges = [-64, -50, -20, 10, 45, 64]          # bands: big | small | big | small | big
    starts = [40.0, 10.0, 12.0, 20.0, 40.0]
    signs = [-1, 1, -1, 1, -1]
    phi = np.full((t.size, Y.size), 0.5)
    for (lo, hi), t0, sg in zip(zip(edges[:-1], edges[1:]), starts, signs):
        m = (Y > lo) & (Y < hi)
        phi[:, m] += sg * np.clip(0.02 * (t - t0), 0, 0.45)[:, None]
    phi[:, 0] = phi[:, -1] = 1.0
    on = band_onsets(t, Y, phi, 0.5, t_ref=80.0, time_smoothing=0.0, smoothing=0.5)
    assert [b["species"] for b in on] == ["big", "small", "big", "small", "big"]
    assert [b["end"] for b in on] == [True, False, False, False, True]
    # |deviation| passes 0.2 ten rotations after each start
    assert [b["onset"] for b in on] == pytest.approx([50.0, 20.0, 22.0, 30.0, 50.0], abs=0.3)
    # periodic: the big band that wraps across y = +-64 is one band
    wrap = phi[:, 1:-1]  # the two big end bands meet across the boundary
    on = band_onsets(t, Y[1:-1], wrap, 0.5, t_ref=80.0, time_smoothing=0.0, smoothing=0.5, periodic=True)
    assert [b["species"] for b in on] == ["big", "small", "big", "small"]
    assert on[0]["y_lo"] > on[0]["y_hi"] and not any(b["end"] for b in on)
    assert on[0]["onset"] == pytest.approx(50.0, abs=0.3)
    # a band that never passes the level has no onset
    assert band_onsets(t, Y, 0.5 + 0.5 * (phi - 0.5) * 0.3, 0.5, 80.0, time_smoothing=0.0)[1]["onset"] is None


def test_section_v_command_prints_each_runs_measures(tmp_path):
    import json
    import subprocess
    import sys

    import h5py
    from synthetic import banded_y, random_bed, species_and_diameters, write_drum_run
    rng = np.random.default_rng(5)
    sp, d = species_and_diameters(rng, 2000)
    beds = [random_bed(rng, 2000, y=banded_y(rng, sp, 6)) for _ in range(12)]
    path = tmp_path / "six.h5"
    write_drum_run(path, np.array(beds), sp, d)
    with h5py.File(path, "r+") as f:
        scene = json.loads(f.attrs["scene_json"])
        scene["particles"] = {"initial_state": "mixed"}
        f.attrs["scene_json"] = json.dumps(scene)
    r = subprocess.run([sys.executable, "-m", "compare", "section-v", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)[str(path)]
    assert v["contrast_last_tenth"] > 0.1 and "band_speed_median" in v
    missing = tmp_path / "missing.h5"
    r = subprocess.run([sys.executable, "-m", "compare", "section-v", str(missing)], capture_output=True, text=True)
    assert r.returncode == 2 and str(missing) in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_claim_verdicts_take_each_side_of_their_margins():
    """Each claim's rule gives agree, disagree and (where it has a middle
    zone) inconclusive on the two sides of its margins (compare/sectionv.py)."""
    from compare import sectionv as sv
    sharp = {"interface_width_first_tenth": 12.0, "mixing_time": None}
    assert sv.no_mixing_verdict(sharp | {"interface_width_last_tenth": 14.0})[0] == "agree"
    assert sv.no_mixing_verdict(sharp | {"interface_width_last_tenth": 16.5})[0] == "inconclusive"
    assert sv.no_mixing_verdict(sharp | {"interface_width_last_tenth": 19.0})[0] == "disagree"
    mixed = sharp | {"interface_width_last_tenth": 12.0, "mixing_time": 800.0}
    assert sv.no_mixing_verdict(mixed)[0] == "disagree"
    assert sv.mixing_verdict(mixed)[0] == "agree" and sv.mixing_verdict(sharp)[0] == "disagree"

    ev = [{"from": 0, "to": 2, "kind": "formation"}, {"from": 2, "to": 4, "kind": "split"}]
    assert sv.events_verdict(ev)[0] == "disagree"  # a split and no merge
    assert sv.events_verdict(ev + [{"from": 4, "to": 2, "kind": "merge"}])[0] == "agree"

    assert sv.exchange_verdict({"exchange_min": -0.9})[0] == "agree"
    assert sv.exchange_verdict({"exchange_min": -0.3})[0] == "inconclusive"
    assert sv.exchange_verdict({"exchange_min": -0.04})[0] == "disagree"

    assert sv.band_speed_verdict({"band_speed_median": 0.008, "band_speed_tracks": 3})[0] == "agree"
    assert sv.band_speed_verdict({"band_speed_median": 0.0002, "band_speed_tracks": 1})[0] == "disagree"
    assert sv.band_speed_verdict({"band_speed_median": 0.05, "band_speed_tracks": 4})[0] == "disagree"
    assert sv.band_speed_verdict({"band_speed_median": None, "band_speed_tracks": 0})[0] == "inconclusive"

    assert sv.capped_ends_verdict(5, ("big", "big"))[0] == "agree"
    assert sv.capped_ends_verdict(4, ("big", "big"))[0] == "disagree"
    assert sv.capped_ends_verdict(5, ("big", "small"))[0] == "disagree"

    assert sv.nucleation_verdict({"onset_interior": [12, 14, 20], "onset_ends": [34, None]})[0] == "agree"
    assert sv.nucleation_verdict({"onset_interior": [12, 40], "onset_ends": [20, None]})[0] == "disagree"

    assert sv.wander_verdict({"pattern_excursion": 10.0, "pattern_wavelength": 32.0}, capped=False)[0] == "agree"
    assert sv.wander_verdict({"pattern_excursion": 40.0, "pattern_wavelength": 32.0}, capped=False)[0] == "disagree"
    assert sv.wander_verdict({"band_speed_median": 5e-5}, capped=True)[0] == "agree"
    assert sv.wander_verdict({"band_speed_median": 0.004}, capped=True)[0] == "disagree"
    assert sv.wander_many_verdict([0.2, 0.4, 0.9])[0] == "agree"
    assert sv.wander_many_verdict([0.2, 0.4, 1.3])[0] == "inconclusive"
    assert sv.wander_many_verdict([0.2, 1.4, 1.3])[0] == "disagree"


def test_blur_verdict_reads_each_part_of_the_claim():
    from compare import sectionv as sv

    def m(width, contrast):
        return {"interface_width_last_tenth": width, "contrast_last_tenth": contrast}
    a = (m(10.0, 0.32), 18.0)
    assert sv.blur_verdict(a, (m(17.0, 0.29), 22.0), (m(21.0, 0.12), 387.0))[0] == "agree"
    # #P's interfaces no wider than #A's: the "starting to blur" part fails
    assert sv.blur_verdict(a, (m(9.0, 0.29), 22.0), (m(21.0, 0.12), 387.0))[0] == "disagree"
    # #Q's contrast only a little below #P's: not decided
    assert sv.blur_verdict(a, (m(17.0, 0.29), 22.0), (m(21.0, 0.27), 387.0))[0] == "inconclusive"
    # #Q's bands no slower than #P's
    assert sv.blur_verdict(a, (m(17.0, 0.29), 22.0), (m(21.0, 0.12), 20.0))[0] == "disagree"
    assert sv.blur_verdict(a, (m(17.0, 0.29), 22.0), (m(21.0, 0.12), None))[0] == "disagree"
