"""Band count and band formation time on synthetic data with known answers,
and on a short real native run."""
import numpy as np
import pytest

from compare.bands import BandCount, BandFormation, count_bands, smooth
from compare.reader import read_run
from synthetic import banded_y, random_bed, species_and_diameters, write_drum_run

N = 4664  # drum #A


@pytest.mark.parametrize("k", [2, 4, 6, 8, 12])
def test_square_profile_with_k_bands_periodic(k):
    y = np.arange(128) + 0.5
    prof = np.where(np.floor(y / (128 / k)) % 2 == 0, 0.3, -0.3)
    assert count_bands(prof, 0.1, 3, periodic=True) == k
    # shifted by a quarter band: still k, wrap-around handled
    assert count_bands(np.roll(prof, 128 // (4 * k)), 0.1, 3, periodic=True) == k


@pytest.mark.parametrize("k", [1, 3, 5, 9, 11])
def test_capped_counts_are_not_forced_even(k):
    y = np.arange(128) + 0.5
    prof = np.where(np.floor(y / (128 / k)) % 2 == 0, 0.3, -0.3)
    assert count_bands(prof, 0.1, 3, periodic=False) == k


def test_noise_spikes_and_gaps_do_not_make_bands():
    prof = np.full(128, 0.3)
    prof[64:] = -0.3
    prof[20] = -0.5           # a one-slice spike: narrower than min_width
    prof[90:93] = 0.0          # an undecided gap inside a band
    assert count_bands(prof, 0.1, 3, periodic=True) == 2
    assert count_bands(np.zeros(128), 0.1, 3, periodic=True) == 0
    # a band that wraps around the periodic end, with an undecided gap right at the cut
    wrap = np.full(128, -0.3)
    wrap[100:] = 0.3
    wrap[:41] = 0.3
    wrap[0:3] = 0.0
    assert count_bands(wrap, 0.1, 3, periodic=True) == 2
    assert count_bands(wrap, 0.1, 3, periodic=False) == 3
    lone = np.zeros(128)
    lone[10:30] = 0.5          # one band and an undecided rest: its complement is the other band
    assert count_bands(lone, 0.1, 3, periodic=True) == 2


def _run(tmp_path, rng, frames_random, frames_banded, k, ends="periodic"):
    species, d = species_and_diameters(rng, N)
    pos = [random_bed(rng, N) for _ in range(frames_random)]
    pos += [random_bed(rng, N, y=banded_y(rng, species, k)) for _ in range(frames_banded)]
    return read_run(write_drum_run(tmp_path / "run.h5", np.array(pos), species, d, ends=ends))


def test_random_mixture_has_no_bands_and_no_formation(tmp_path):
    run = _run(tmp_path, np.random.default_rng(1), 40, 0, 2)
    bands = BandCount().compute(run)
    assert np.all(bands.counts == 0)
    assert bands.final == 0
    form = BandFormation().compute(run)
    assert form.formation_time is None
    # the order parameter of a random mixture is of order one by construction
    assert 0.3 < np.median(form.order_parameter) < 1.5


@pytest.mark.parametrize("k", [4, 8])
def test_imposed_bands_are_counted_and_formation_time_found(tmp_path, k):
    run = _run(tmp_path, np.random.default_rng(2), 20, 20, k)
    bands = BandCount().compute(run)
    assert np.all(bands.counts[:20] == 0)
    assert np.all(bands.counts[20:] == k)
    assert bands.final == k
    form = BandFormation(threshold=3.0, window=5.0).compute(run)
    # bands switched on at rotation 20; the centred 5-rotation mean crosses
    # the threshold at most half a window earlier
    assert form.formation_time is not None
    assert 17.0 <= form.formation_time <= 20.0
    assert form.dominant_mode[-1] == k // 2  # k bands = k/2 wavelengths


def test_capped_imposed_bands(tmp_path):
    run = _run(tmp_path, np.random.default_rng(3), 5, 10, 5, ends="capped")
    assert BandCount().compute(run).final == 5


def test_bands_that_dissolve_have_no_formation_time(tmp_path):
    rng = np.random.default_rng(4)
    species, d = species_and_diameters(rng, N)
    pos = [random_bed(rng, N, y=banded_y(rng, species, 6)) for _ in range(20)]
    pos += [random_bed(rng, N) for _ in range(20)]
    run = read_run(write_drum_run(tmp_path / "run.h5", np.array(pos), species, d))
    assert BandFormation().compute(run).formation_time is None  # crossed, but did not stay above


def test_threshold_is_a_parameter(tmp_path):
    run = _run(tmp_path, np.random.default_rng(5), 10, 10, 4)
    low = BandFormation(threshold=3.0).compute(run).formation_time
    assert low is not None
    assert BandFormation(threshold=1e6).compute(run).formation_time is None


def test_results_before_compute_raise():
    with pytest.raises(RuntimeError):
        BandCount().counts
    with pytest.raises(RuntimeError):
        BandFormation().formation_time


def test_a_sparse_end_slice_does_not_erase_the_end_band():
    """Near a cap the last slice may hold a single particle, so its
    concentration is 0 or 1. Smoothing weights each slice by its particle
    volume (normalised convolution), so that slice cannot swamp the band next
    to it. The profile here is drum #R's final one in outline: a weakly
    big-rich end band and one small particle alone in the last slice."""
    dev = np.full(128, 0.3)
    dev[:40] = -0.3
    dev[112:] = -0.2          # big-rich end band
    dev[127] = 0.7            # the lone small particle
    w = np.ones(128)
    w[127] = 0.05             # ... in a slice holding 5 % of a normal slice's volume
    sm = smooth(dev, 2.0, periodic=False, weights=w)
    np.testing.assert_allclose(sm[118:], -0.2, atol=0.03)
    assert count_bands(sm, 0.15, 3, periodic=False) == 3
    # without the weights the spike pulls the band's end up to the mean and beyond
    assert smooth(dev, 2.0, periodic=False)[127] > 0.0


def test_band_events_on_a_known_history():
    """A count of 8 from rotation 20, merging to 6 at rotation 1000, with 5 %
    of samples flickering by a pair and a 20-rotation excursion to 4: one
    formation and one merge, at the right rotations; the flicker and the
    short excursion are not events."""
    from compare.bands import band_events, lasting_count
    t = np.arange(0.0, 3000.0)
    rng = np.random.default_rng(1)
    c = np.where(t < 20, 0, np.where(t < 1000, 8, 6))
    c = np.clip(c + np.where(rng.random(t.size) < 0.05, rng.choice([-2, 2], t.size), 0), 0, None)
    c[1500:1520] = 4
    ev = band_events(t, c, window=50.0)
    assert [(e["kind"], e["from"], e["to"]) for e in ev] == [("formation", 0, 8), ("merge", 8, 6)]
    assert abs(ev[0]["rotation"] - 20) <= 25 and abs(ev[1]["rotation"] - 1000) <= 25
    assert lasting_count(t, c, 50.0)[1510] == 6


def test_band_events_split_and_mixing():
    from compare.bands import band_events
    t = np.arange(0.0, 1000.0)
    c = np.where(t < 300, 2, np.where(t < 700, 4, 0))
    kinds = [(e["kind"], e["rotation"]) for e in band_events(t, c, window=50.0)]
    assert [k for k, _ in kinds] == ["split", "mixing"]
    assert abs(kinds[0][1] - 300) <= 25 and abs(kinds[1][1] - 700) <= 25
    assert band_events(t[:0], c[:0]) == []
