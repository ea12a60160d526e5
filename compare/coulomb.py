"""How often the Coulomb cap binds, from the census the native engine writes
(group ``/coulomb``, native/src/engine/coulomb_census.hpp).

At each sample the engine evaluates the scene's law on every contact and
counts the contacts with |F_t| >= mu |F_n| (to 1e-9 relative): for a capped
law the contacts where the cap is active, for YADE's uncapped law the contacts
where a cap with the mapped law's mu would have bound.  This class averages
the counts over the samples after ``skip`` (in the run's own time unit) and
reports the fraction per species pair and per wall species.
"""
from __future__ import annotations

import numpy as np

from ._common import Result
from .reader import read_series

DRUM_SPECIES = ("small", "big", "wall particle")
BOX_SPECIES = ("grain", "big", "wall particle")


def read_census(path):
    """The census as a dict of arrays, or None if the file has none."""
    return read_series(path, "coulomb")


class CoulombCap(Result):
    """Fraction of contacts at the Coulomb cap.

    skip: samples with time < skip are left out (the fill or the settling).
    """

    def __init__(self, skip=0.0, names=DRUM_SPECIES):
        self.skip = float(skip)
        self.names = names

    def compute(self, path):
        c = read_census(path)
        if c is None:
            raise ValueError(f"{path}: no /coulomb census in the file")
        keep = c["time"] >= self.skip
        if not keep.any():  # a run shorter than the skip: nothing to average
            self._result = {"samples": 0, "pair_at_cap": None, "wall_at_cap": None, "all_at_cap": None,
                            "pairs": {}, "walls": {}, "time": c["time"],
                            "per_sample": np.full(c["time"].shape, np.nan)}
            return self
        pc, pk = c["pair_contacts"][keep], c["pair_at_cap"][keep]
        wc, wk = c["wall_contacts"][keep], c["wall_at_cap"][keep]
        s = int(round(np.sqrt(pc.shape[1])))
        pairs = {}
        for a in range(s):
            for b in range(a, s):
                n = pc[:, a * s + b].sum()
                if n > 0:
                    pairs[f"{self.names[a]}-{self.names[b]}"] = {
                        "contacts_per_sample": n / keep.sum(), "at_cap": pk[:, a * s + b].sum() / n}
        walls = {}
        for a in range(s):
            n = wc[:, a].sum()
            if n > 0:
                walls[self.names[a]] = {"contacts_per_sample": n / keep.sum(), "at_cap": wk[:, a].sum() / n}
        per_sample = (pk.sum(1) + wk.sum(1)) / np.maximum(pc.sum(1) + wc.sum(1), 1)
        self._result = {
            "samples": int(keep.sum()),
            "pair_at_cap": pk.sum() / max(pc.sum(), 1),
            "wall_at_cap": wk.sum() / wc.sum() if wc.sum() > 0 else None,
            "all_at_cap": (pk.sum() + wk.sum()) / max(pc.sum() + wc.sum(), 1),
            "pairs": pairs, "walls": walls,
            "time": c["time"], "per_sample": per_sample,
        }
        return self

    @property
    def all_at_cap(self):
        return self._get("all_at_cap")

    @property
    def pair_at_cap(self):
        return self._get("pair_at_cap")

    @property
    def wall_at_cap(self):
        return self._get("wall_at_cap")

    def pairs_fraction(self, name):
        """The fraction at the cap for one species pair, e.g. "small-big"."""
        return self._get("pairs")[name]["at_cap"]

    def as_dict(self):
        return {k: self._get(k) for k in ("samples", "all_at_cap", "pair_at_cap", "wall_at_cap", "pairs", "walls")}

    def plot(self, ax=None):
        if ax is None:
            from matplotlib.figure import Figure
            ax = Figure().add_subplot()
        ax.plot(self._get("time"), self._get("per_sample"))
        ax.axvline(self.skip, color="0.6", lw=0.8)
        ax.set_xlabel("time")
        ax.set_ylabel("fraction of contacts at the Coulomb cap")
        return ax
