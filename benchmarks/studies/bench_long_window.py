"""Long-window trust scores (issue 9): reduced formulations against the independent full order
over windows of seconds — envelope error and, fitted over the quasi-steady part, the secular
cone-growth rate, the mean dissipated power and the spin-rate change, each reduced / full.

Run the comparisons (one full-order transient per spin rate; 10-12 min each on the coarse
model at 0.25 ms over 4 s, about 45 min on the default mesh over 2 s):

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_long_window run \
        --case paper-41hz-coarse --spins 41,20 --window "4 s" --full-dt "0.25 ms" \
        [--modes 8] [--reference spinning] [--formulations Q,Q4] --out out/long-window

or print the table of comparisons already made (``comparison.json`` of ``quadmodes compare``):

    python -m benchmarks.studies.bench_long_window table out/long-window/*/comparison.json

Targets (issue 9): envelope within 3 %, each ratio within 5 % of 1.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

TARGETS = {"envelope_error": 0.03, "cone_growth_ratio": 0.05, "dissipated_power_ratio": 0.05,
           "spin_rate_change_ratio": 0.05}  # fmt: skip


def table(payloads: list[dict]) -> str:
    """Markdown table: one row per (comparison, formulation), with a pass mark per target."""
    lines = ["| case | spin (Hz) | N | reference | model | envelope | cone growth | diss. power "
             "| spin change | full order: cone growth (deg/s), power (W), fit (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for p in payloads:
        q = p["quasi_steady"]
        full = q["full_order"]
        ref = (f"{full['cone_growth_deg_per_s']:.5f}, {full['dissipated_power_W']:.5f}, "
               f"{q['start_s']:g}–{q['end_s']:g}")  # fmt: skip
        for name, row in p["formulations"].items():
            cells = []
            for key, tol in TARGETS.items():
                v = row.get(key)
                if v is None:
                    cells.append("—")
                    continue
                err = v if key == "envelope_error" else v - 1.0
                mark = "✓" if abs(err) <= tol else "✗"
                cells.append(f"{v:.4f} {mark}" if key == "envelope_error" else f"× {v:.3f} {mark}")
            meta = p.get("meta", {})
            lines.append(f"| {p['case']} | {meta.get('spin_hz', '')} | {meta.get('modes', '')} | "
                         f"{meta.get('reference', '')} | {name} | " + " | ".join(cells)
                         + f" | {ref} |")  # fmt: skip
    return "\n".join(lines)


def run(args) -> None:
    from quadmodes.analysis.compare import compare
    from quadmodes.case import load_run_case
    from quadmodes.case.units import parse_quantity

    window = parse_quantity(args.window, "time", "--window")
    full_dt = parse_quantity(args.full_dt, "time", "--full-dt")
    payloads = []
    for spin in (float(s) for s in args.spins.split(",")):
        base = load_run_case(args.case)
        red = base.reduced.model_copy(update={k: v for k, v in (
            ("modes", None if args.modes is None else (args.modes if args.modes == "auto"
                                                        else int(args.modes))),
            ("reference", args.reference)) if v is not None})  # fmt: skip
        ini = base.initial.model_copy(update={"spin_rate": 2.0 * 3.141592653589793 * spin})
        run_case = base.model_copy(update={"reduced": red, "initial": ini})
        cmp = compare(run_case, window, formulations=tuple(args.formulations.split(",")),
                      full_order_dt=full_dt)  # fmt: skip
        payload = cmp.as_json()
        payload["meta"] = {"spin_hz": spin, "modes": cmp.run.reduced.modes,
                           "reference": cmp.run.reduced.reference}  # fmt: skip
        folder = Path(args.out) / f"{args.case}-{spin:g}Hz"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "comparison.json").write_text(json.dumps(payload, indent=1) + "\n")
        payloads.append(payload)
        print(table([payload]), flush=True)
    print(table(payloads))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("--case", default="paper-41hz-coarse")
    r.add_argument("--spins", default="41,20", help="Hz, comma-separated")
    r.add_argument("--window", default="4 s")
    r.add_argument("--full-dt", default="0.25 ms")
    r.add_argument("--modes", default=None)
    r.add_argument("--reference", default=None, choices=("rest", "spinning"))
    r.add_argument("--formulations", default="Q,Q4")
    r.add_argument("--out", default="out/long-window")
    t = sub.add_parser("table")
    t.add_argument("files", nargs="+")
    args = ap.parse_args()
    if args.command == "run":
        run(args)
    else:
        print(table([json.loads(Path(f).read_text()) for f in args.files]))


if __name__ == "__main__":
    main()
