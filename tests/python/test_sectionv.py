"""Section V's long-run measures on synthetic profiles with known answers."""
import numpy as np
import pytest

from compare.sectionv import (band_speed, contrast, end_species, exchange, interface_width, interfaces,
                              lasting_below, pattern_excursion)

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
