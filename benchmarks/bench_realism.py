"""How the built-in face's wrinkles read: furrow counts, depths and slopes, furrow runs,
the direction of the normals' change, folds and turned-over triangles.

Run:  .venv/bin/python benchmarks/bench_realism.py [--triangles 4500 60000] [--refine]
      [--skin geometric|physical] [--face lee_perry_smith] [--json FILE]

``--skin physical`` measures the physically based skin's frames (its equilibrium,
``evaluate(skin="physical")``). ``--face lee_perry_smith`` measures the scanned head
instead of the procedural face; its forehead and glabella lie elsewhere than the sections
below, so only the crease and the turned-over counts are measured there.

For "surprise", "frown" and "fear" it evaluates the face and measures with
:mod:`wrinkle_vis.core.analysis` (no display needed):

- surprise: along the vertical sections x = -40, -24, -8, 8, 24, 40 mm of the rest skin,
  restricted to the union of the wrinkling regions of the ``frontalis*`` muscles, the crests
  and furrows of the total amplitude W (prominence 0.1 mm), beside those muscles' n_w; the
  median furrow depth and side slope over those sections; the furrow runs followed across
  sections every 2 mm from x = -60 to 60 (max jump 3 mm) that are at least 60 mm long; and
  the fraction of the normals' change that runs across the first frontalis sheet's fibre
  (1: furrows straight across the fibre) over the frontalis regions.
- frown: crests and furrows along the horizontal sections y = 20, 24, 28 mm, restricted to
  |x| < 20 mm and the corrugators' regions; the median furrow depth.
- every expression: the 99th percentile and maximum of the change of the dihedral angles
  from rest to the deformed skin (muscle displacement alone, before wrinkles) over the edges
  with a moved vertex, and the number of triangles turned over (their normal against the
  rest normal) at intensities 0.25, 0.5, 0.75 and 1, on the final skin and on the deformed
  one.

Distances are measured on the rest skin (W's slope is dW/ds along the rest section). With
``--refine`` each frame is ``face.evaluate(expr, refine=True)`` and everything is measured on
its refined skin (``state.face.skin``). ``report(face, refine)`` returns the numbers as a
dict for tuning scripts.
"""

import argparse
import json
import time

import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.core.analysis import (
    dihedral_change,
    furrow_runs,
    normal_change_anisotropy,
    region_union,
    section_extrema,
    turned_over,
)

EXPRESSIONS = ("surprise", "frown", "fear")
FOREHEAD_X = (-40.0, -24.0, -8.0, 8.0, 24.0, 40.0)
RUN_X = np.arange(-60.0, 60.0 + 1e-9, 2.0)
FROWN_Y = (20.0, 24.0, 28.0)
FROWN_HALF_WIDTH = 20.0
PROMINENCE = 0.1  # mm: deeper than the ripple Eq. 10's mesh noise leaves on a bulge
MAX_JUMP = 3.0  # mm
LONG_RUN = 60.0  # mm
INTENSITIES = (0.25, 0.5, 0.75, 1.0)


def _median(values) -> float:
    return float(np.median(values)) if len(values) else float("nan")


def folds_and_flips(face, expression: str, state, refine: bool) -> dict:
    """Dihedral change from rest to the deformed skin and turned-over counts."""
    surface, rest = state.face.skin, state.rest_points
    moved = (state.deformed_points != rest).any(axis=1)
    change = dihedral_change(surface, rest, state.deformed_points)
    change = change[moved[surface.edges].any(axis=1)]
    change = change[np.isfinite(change)]
    flips_final, flips_deformed = {}, {}
    for k in INTENSITIES:
        s = face.evaluate(expression, k, refine=refine)
        flips_final[k] = int(turned_over(s.face.skin, s.rest_points, s.points).sum())
        flips_deformed[k] = int(turned_over(s.face.skin, s.rest_points,
                                            s.deformed_points).sum())
    return {
        "moved_edges": int(len(change)),
        "dihedral_p99_deg": float(np.percentile(change, 99)) if len(change) else 0.0,
        "dihedral_max_deg": float(change.max()) if len(change) else 0.0,
        "turned_over": flips_final,
        "turned_over_deformed": flips_deformed,
    }


def forehead(state) -> dict:
    """The surprise measurements on a frame."""
    face, surface, rest, W = state.face, state.face.skin, state.rest_points, state.W
    mask = region_union(face, "frontalis")
    rows = section_extrema(surface, W, 0, FOREHEAD_X, mask, PROMINENCE)
    runs = furrow_runs(surface, W, RUN_X, 0, mask, PROMINENCE, MAX_JUMP)
    sheet = next(m for m in face.muscles
                 if m.name.startswith("frontalis") and isinstance(m, wv.SheetMuscle))
    return {
        "sections": rows,
        "n_wrinkles": {m.name: int(m.n_wrinkles) for m in face.muscles
                       if m.name.startswith("frontalis")},
        "furrow_depth_median": _median([d for r in rows for d in r["depths"]]),
        "side_slope_median_deg": _median([d for r in rows for d in r["side_slopes_deg"]]),
        "long_runs": int(sum(r.length >= LONG_RUN for r in runs)),
        "run_lengths": [round(r.length, 3) for r in runs if r.length > 0],
        "anisotropy": normal_change_anisotropy(surface, rest, state.points, sheet.frame[0],
                                               mask),
        "anisotropy_fibre": sheet.name,
    }


def glabella(state) -> dict:
    """The frown measurements on a frame."""
    rest = state.rest_points
    mask = region_union(state.face, "corrugator")
    mask &= np.abs(rest[:, 0]) < FROWN_HALF_WIDTH
    rows = section_extrema(state.face.skin, state.W, 1, FROWN_Y, mask, PROMINENCE)
    return {"sections": rows,
            "furrow_depth_median": _median([d for r in rows for d in r["depths"]])}


def report(face, refine: bool = False, sections: bool = True) -> dict:
    """Every number the script prints, for ``face`` (a built-in-like face).

    Returns
    -------
    dict
        ``{expression: {...}}`` with the keys of :func:`forehead` (surprise),
        :func:`glabella` (frown) and :func:`folds_and_flips` (all), ``W_min``, ``W_max``,
        ``n_triangles`` and the times ``evaluate_s`` and ``analysis_s``; without
        ``sections`` only :func:`folds_and_flips`.
    """
    out = {"n_triangles_rest": int(face.skin.n_triangles), "refine": bool(refine)}
    for expr in EXPRESSIONS:
        t0 = time.perf_counter()
        state = face.evaluate(expr, refine=refine)
        t1 = time.perf_counter()
        entry = {"n_triangles": int(len(state.triangles)), "W_min": float(state.W.min()),
                 "W_max": float(state.W.max())}
        if expr == "surprise" and sections:
            entry.update(forehead(state))
        if expr == "frown" and sections:
            entry.update(glabella(state))
        entry.update(folds_and_flips(face, expr, state, refine))
        entry["evaluate_s"] = t1 - t0
        entry["analysis_s"] = time.perf_counter() - t1
        out[expr] = entry
    return out


# ---------------------------------------------------------------------- printing
def _row(label: str, values, fmt: str = "{:>6}") -> str:
    return f"    {label:<30s}" + "".join(fmt.format(v) for v in values)


def _pairs(n_wrinkles: dict) -> str:
    """``frontalis_inner 3`` for a pair with equal n_w, else both sides."""
    parts, seen = [], set()
    for name, n in n_wrinkles.items():
        base = name[:-2] if name[-2:] in ("_L", "_R") else name
        if base in seen:
            continue
        seen.add(base)
        sides = {k: v for k, v in n_wrinkles.items() if k in (base + "_L", base + "_R")}
        same = len(set(sides.values())) == 1
        parts.append(f"{base.removeprefix('frontalis_')} {n}" if same else
                     ", ".join(f"{k} {v}" for k, v in sides.items()))
    return ", ".join(parts)


def print_report(r: dict) -> None:
    print(f"{r.get('face', 'built-in face')}, {r.get('skin', 'geometric')} skin, "
          f"{r['n_triangles_rest']} triangles"
          f"{', refined frames' if r['refine'] else ''}")
    for expr in EXPRESSIONS:
        e = r[expr]
        print(f"{expr}: {e['n_triangles']} triangles, W {e['W_min']:+.3f}..{e['W_max']:+.3f} "
              f"mm; evaluate "
              f"{1e3 * e['evaluate_s']:.0f} ms, measure {1e3 * e['analysis_s']:.0f} ms")
        if "sections" in e:
            rows = e["sections"]
            axis = "x" if expr == "surprise" else "y"
            where = "frontalis regions" if expr == "surprise" else \
                f"corrugator regions, |x| < {FROWN_HALF_WIDTH:g}"
            print(f"  sections {axis} = c [mm] inside the {where}, prominence {PROMINENCE} mm")
            print(_row(f"{axis} [mm]", [f"{row['offset']:g}" for row in rows]))
            print(_row("section length [mm]", [f"{row['length']:.0f}" for row in rows]))
            print(_row("crests", [row["crests"] for row in rows]))
            print(_row("furrows", [row["furrows"] for row in rows]))
            print(_row("median furrow depth [mm]", [
                f"{_median(row['depths']):.2f}" if row["depths"] else "-" for row in rows]))
            if expr == "surprise":
                print(_row("median side slope [deg]", [
                    f"{_median(row['side_slopes_deg']):.1f}" if row["depths"] else "-"
                    for row in rows]))
                print(f"    n_w: {_pairs(e['n_wrinkles'])}")
            line = f"  furrow depth median {e['furrow_depth_median']:.3f} mm"
            if expr == "surprise":
                line += f", side slope median {e['side_slope_median_deg']:.1f} deg"
            print(line)
        if "long_runs" in e:
            longest = ", ".join(f"{x:.0f}" for x in e["run_lengths"][:6]) or "none"
            print(f"  furrow runs >= {LONG_RUN:g} mm: {e['long_runs']} (longest: {longest} mm;"
                  f" sections x = {RUN_X[0]:g}..{RUN_X[-1]:g} every 2 mm, max jump "
                  f"{MAX_JUMP:g} mm)")
            print(f"  normal change across the {e['anisotropy_fibre']} fibre: "
                  f"{e['anisotropy']:.3f}  (1 = furrows straight across, 0.5 = no direction)")
        print(f"  dihedral change, displacement only: p99 {e['dihedral_p99_deg']:.2f} deg, "
              f"max {e['dihedral_max_deg']:.2f} deg over {e['moved_edges']} edges")
        ks = "/".join(f"{k:g}" for k in INTENSITIES)
        fin = "/".join(str(e["turned_over"][k]) for k in INTENSITIES)
        dfm = "/".join(str(e["turned_over_deformed"][k]) for k in INTENSITIES)
        print(f"  turned over at intensity {ks}: {fin} final, {dfm} deformed")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, nargs="+", default=[4500],
                        help="face sizes (default 4500)")
    parser.add_argument("--refine", action="store_true", help="measure refined frames")
    parser.add_argument("--skin", choices=("geometric", "physical"), default="geometric",
                        help="the skin model (default geometric)")
    parser.add_argument("--face", default="procedural",
                        help="built-in face (procedural or lee_perry_smith)")
    parser.add_argument("--json", help="also write the numbers to this file")
    args = parser.parse_args()
    print(f"load average {open('/proc/loadavg').read().split()[0]}")
    results = []
    procedural = args.face == "procedural"
    for n in args.triangles if procedural else [None]:
        t0 = time.perf_counter()
        face = wv.datasets.load_face(args.face, n).with_skin_model(args.skin)
        print(f"load_face({args.face!r}, {n}): {time.perf_counter() - t0:.1f} s")
        t0 = time.perf_counter()
        r = report(face, refine=args.refine, sections=procedural)
        r.update(face=args.face, skin=args.skin)
        print_report(r)
        print(f"report: {time.perf_counter() - t0:.1f} s\n")
        results.append(r)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=1, default=str)


if __name__ == "__main__":
    main()
