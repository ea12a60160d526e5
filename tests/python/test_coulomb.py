"""The Coulomb-cap census: the fractions compare/coulomb.py derives from the
counts, and the census a real native drum run writes."""
import h5py
import numpy as np
import pytest

from compare.coulomb import CoulombCap

from test_native_run import BIN, SCENE_A, granular


def write_census(path, time, pair_contacts, pair_at_cap, wall_contacts, wall_at_cap):
    with h5py.File(path, "w") as h5:
        g = h5.create_group("coulomb")
        for k, v in dict(time=time, pair_contacts=pair_contacts, pair_at_cap=pair_at_cap,
                         wall_contacts=wall_contacts, wall_at_cap=wall_at_cap).items():
            g[k] = np.asarray(v, dtype=np.float64)


def test_fractions_from_known_counts(tmp_path):
    S = 3
    pc = np.zeros((3, S * S)); pk = np.zeros((3, S * S))
    wc = np.zeros((3, S)); wk = np.zeros((3, S))
    pc[:, 0] = 100; pk[:, 0] = [90, 30, 10]          # grain-grain: 40 of 200 after the skip
    pc[:, 2] = 10;  pk[:, 2] = [10, 5, 0]            # grain-wall: 5 of 20
    wc[:, 1] = 4;   wk[:, 1] = [4, 4, 2]             # big on a smooth wall: 6 of 8
    p = tmp_path / "c.h5"
    write_census(p, [0.0, 1.0, 2.0], pc, pk, wc, wk)
    c = CoulombCap(skip=0.5, names=("grain", "big", "wall particle")).compute(p)
    assert c.as_dict()["samples"] == 2
    assert c.pairs_fraction("grain-grain") == pytest.approx(40 / 200)
    assert c.pairs_fraction("grain-wall particle") == pytest.approx(5 / 20)
    assert c.pair_at_cap == pytest.approx(45 / 220)
    assert c.wall_at_cap == pytest.approx(6 / 8)
    assert c.all_at_cap == pytest.approx(51 / 228)
    assert "big-big" not in c.as_dict()["pairs"]  # no contacts: no entry


def test_skip_past_the_end_gives_no_fraction(tmp_path):
    p = tmp_path / "c.h5"
    write_census(p, [0.0], np.ones((1, 4)), np.ones((1, 4)), np.ones((1, 2)), np.zeros((1, 2)))
    c = CoulombCap(skip=5.0).compute(p)
    assert c.as_dict()["samples"] == 0 and c.all_at_cap is None


@pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")
def test_real_run_census_capped_and_uncapped(tmp_path):
    """Drum #A in its first 0.4 rotations: the paper's law puts a sizeable share
    of contacts on the cap (the grains slide on the wall and on each other while
    the bed is set in motion); YADE's uncapped law, with the same mapped mu,
    exceeds it on a sizeable share too, and never on every contact."""
    fr = {}
    for law in ("rapaport", "viscel"):
        out = tmp_path / f"{law}.h5"
        granular("run", SCENE_A, "-o", out, "--threads", "1", "--set", "run.rotations=0.4",
                 "--set", "run.profile_every=0.05", "--set", f"contact.law={law}")
        with h5py.File(out) as h5:
            n = h5["coulomb/time"].shape[0]
            assert n == h5["profile/time"].shape[0]  # one census per profile sample
            assert np.all(h5["coulomb/pair_at_cap"][()] <= h5["coulomb/pair_contacts"][()])
            assert np.all(h5["coulomb/wall_at_cap"][()] <= h5["coulomb/wall_contacts"][()])
        fr[law] = CoulombCap(skip=0.0).compute(out)
        assert 0.05 < fr[law].all_at_cap < 0.95
        assert fr[law].wall_at_cap is not None
