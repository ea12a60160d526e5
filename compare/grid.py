"""Observables of a grid of runs, grouped by set-up: what a model choice or a
time step changes (docs/speed_accuracy.md).

    /usr/bin/python3 -m compare grid RUN.h5 ... [-o DIR] [--reference NAME]

Run files are named SETUP_sSEED.h5 (drum) or SETUP_fFREQ_sSEED.h5 (box), e.g.
gear5e-5_f3.2_s1.h5; a run counts once its engine has finished it (a
RUN.h5.done marker, or a validation run's RUN.json). Per set-up (and
frequency) the same observables and statistics as `compare validate`: mean and
sample standard deviation per scalar, k of n with the 95 % Clopper-Pearson
interval for the box's rise and convection. With --reference, each other
set-up's difference from it, against the margins of docs/tolerances.md.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

from ._common import clean_json
from .validate import MARGINS, binomial, box_observables, drum_observables, summary

NAME = re.compile(r"^(?P<setup>.+?)(?:_f(?P<freq>[0-9.]+))?_s(?P<seed>\d+)$")
SCALARS = {"drum": ["slope_deg", "bands_final", "formation_rotations"], "box": ["phi_max", "bed_height"]}


def finished(path: Path) -> bool:
    return Path(str(path) + ".done").exists() or path.with_suffix(".json").exists()


def parse(path: Path):
    m = NAME.match(path.stem)
    if not m:
        raise SystemExit(f"{path}: not named SETUP_sSEED.h5 or SETUP_fFREQ_sSEED.h5")
    return m["setup"], (float(m["freq"]) if m["freq"] else None), int(m["seed"])


def kind_of(path: Path) -> str:
    import h5py
    with h5py.File(path, "r") as h:
        k = h.attrs["scene_kind"]
    return "drum" if (k.decode() if isinstance(k, bytes) else k) == "drum" else "box"


def grid(paths, reference=None):
    groups = {}
    skipped = []
    for p in sorted(Path(x) for x in paths):
        if not finished(p):
            skipped.append(str(p))
            continue
        setup, freq, seed = parse(p)
        kind = kind_of(p)
        obs = drum_observables(p, {}) if kind == "drum" else box_observables(p)
        g = groups.setdefault((setup, freq), {"setup": setup, "frequency": freq, "kind": kind, "runs": []})
        g["runs"].append({"seed": seed, "path": str(p)} | {k: obs.get(k) for k in
                                                           SCALARS[kind] + ["rose", "convecting"]})
    rows = []
    for (setup, freq), g in sorted(groups.items(), key=lambda kv: (kv[0][1] or 0.0, kv[0][0])):
        runs = g["runs"]
        g["summary"] = {k: summary([r[k] for r in runs]) for k in SCALARS[g["kind"]]}
        if g["kind"] == "box":
            for k in ("rose", "convecting"):
                v = [bool(r[k]) for r in runs if r[k] is not None]
                g[k] = binomial(sum(v), len(v)) if v else None
        rows.append(g)
    if reference:
        ref = {r["frequency"]: r for r in rows if r["setup"] == reference}
        for r in rows:
            base = ref.get(r["frequency"])
            if base is None or r is base:
                continue
            r["against_reference"] = {}
            for k, s in r["summary"].items():
                a, b = base["summary"][k]["mean"], s["mean"]
                if a is None or b is None:
                    continue
                limit = MARGINS[k]
                r["against_reference"][k] = {"difference": b - a, "tolerance": limit, "within": abs(b - a) <= limit}
            if r["kind"] == "box":
                for k in ("rose", "convecting"):
                    if r.get(k) and base.get(k):
                        lo = r[k]["ci95"][0] <= base[k]["ci95"][1] and base[k]["ci95"][0] <= r[k]["ci95"][1]
                        r["against_reference"][k] = {"overlap": lo}
    return {"rows": rows, "skipped_unfinished": skipped, "reference": reference}


def fmt(s, digits=1):
    if not s or s["mean"] is None:
        return "–"
    sd = f" ± {s['sd']:.{digits}f}" if s["n"] > 1 else ""
    und = f" ({s['undefined']} undefined)" if s["undefined"] else ""
    return f"{s['mean']:.{digits}f}{sd}{und}"


def markdown(rep):
    rows = rep["rows"]
    if not rows:
        return "(no finished runs)\n"
    kind = rows[0]["kind"]
    if kind == "drum":
        head = "| set-up | runs | slope (°) | bands at the end | formation (rotations) |\n|---|---|---|---|---|\n"
        body = "".join(f"| {r['setup']} | {len(r['runs'])} | {fmt(r['summary']['slope_deg'])} | "
                       f"{fmt(r['summary']['bands_final'])} | {fmt(r['summary']['formation_rotations'])} |\n"
                       for r in rows)
    else:
        def kn(b):
            return "–" if not b else f"{b['k']}/{b['n']} [{b['ci95'][0]:.2f}, {b['ci95'][1]:.2f}]"
        head = ("| f (Hz) | set-up | runs | big disk rose | convecting | Φ_max (grains/cycle) | bed height (cm) |\n"
                "|---|---|---|---|---|---|---|\n")
        body = "".join(f"| {r['frequency']:g} | {r['setup']} | {len(r['runs'])} | {kn(r.get('rose'))} | "
                       f"{kn(r.get('convecting'))} | {fmt(r['summary']['phi_max'])} | "
                       f"{fmt(r['summary']['bed_height'], 2)} |\n" for r in rows)
    out = head + body
    flagged = [(r, k, v) for r in rows for k, v in r.get("against_reference", {}).items()
               if v.get("within") is False or v.get("overlap") is False]
    compared = sum(len(r.get("against_reference", {})) for r in rows)
    if rep["reference"] and not compared:
        out += f"\nAgainst {rep['reference']}: nothing to compare yet (no finished reference run at these frequencies).\n"
    elif rep["reference"]:
        out += (f"\nAgainst {rep['reference']} ({compared} comparisons): " + ("every difference within its tolerance "
                "and every interval overlapping." if not flagged else "; ".join(
                    f"{r['setup']}{'' if r['frequency'] is None else ' at %g Hz' % r['frequency']} {k} "
                    + (f"differs by {v['difference']:.3g} (tolerance {v['tolerance']:.3g})" if 'difference' in v
                       else "interval does not overlap") for r, k, v in flagged)) + "\n")
    if rep["skipped_unfinished"]:
        out += f"\n{len(rep['skipped_unfinished'])} unfinished run(s) left out.\n"
    return out


def main(paths, output=None, reference=None):
    rep = grid(paths, reference)
    if output:
        Path(output).mkdir(parents=True, exist_ok=True)
        (Path(output) / "grid.json").write_text(json.dumps(clean_json(rep), indent=1))
    return rep, markdown(rep)
