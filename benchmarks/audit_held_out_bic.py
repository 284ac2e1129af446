"""Audit ``DiagnoseSettings.held_out_bic`` on stored blind-study draws (issue 5).

    python benchmarks/audit_held_out_bic.py W1 W2 ... [--level L] [--min-error-ratio R]

Each ``W`` is a workdir of ``benchmarks/blind_diagnosis.py`` holding ``key.json`` and the
full ``diagnoses.json`` (the markdown reports do not keep the candidates' details).  A
nonlinear candidate (``rate_limit``, ``backlash``, ``saturation``) whose identification
error cut is small (under ``--min-error-ratio``) and whose amplitude test is silent has an
effect size only from the held-out records' BIC against the null refit (see
``jaxgwo._diagnose._effect_size_passes``).  Two lists, in every ranking of every case:

- ``sized with a small cut``: such candidates whose size passed, with the held-out BIC
  difference (the size's usual source there; a ``J`` far beyond noise is the other) and
  whether the candidate beat noise;
- ``refused by the level``: such candidates whose size failed, that act on the held-out
  records and whose held-out BIC improved by less than ``--level`` (``-level <= dBIC < 0``):
  those ``held_out_bic`` refused and a level of 0 (any improvement) would have sized.

Each line gives the truth from the key beside the case's verdict, so an audit tells right
verdicts the level removed from false alarms it prevented.  It reads the diagnoses as
stored; nothing is diagnosed again.  Pass draws diagnosed on a commit that has
``held_out_bic`` (82e42d4 or later) for the refusals to be the rule's own; ``--level`` and
``--min-error-ratio`` default to :class:`DiagnoseSettings`' values.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from jaxgwo._diagnose import DiagnoseSettings
from jaxgwo._diagnose_which import NONLINEAR

DEFAULTS = DiagnoseSettings()
RANKINGS = ("ranking", "ranking_paper_model")


def small_cut_candidates(report: dict, min_error_ratio: float):
    """Yield ``(ranking name, place, candidate, cut)`` for the nonlinear candidates whose
    error cut (null refit's error over the candidate's) is under ``min_error_ratio`` and whose
    amplitude test did not back them: those whose size can only come from the held-out BIC."""
    for name in RANKINGS:
        for place, cand in enumerate(report.get(name) or []):
            det = cand.get("detail") or {}
            if cand["effect"] not in NONLINEAR or not det.get("train_mse"):
                continue
            cut = det["null_train_mse"] / det["train_mse"]
            if cut < min_error_ratio and det.get("amplitude_corroborates") != 1.0:
                yield name, place, cand, cut


def audit(workdirs: list[Path], level: float, min_error_ratio: float) -> tuple[list[str], list[str]]:
    """The two lists of the module docstring, as printable lines."""
    sized, refused = [], []
    for w in workdirs:
        for f in ("diagnoses.json", "key.json"):
            if not (w / f).is_file():
                raise SystemExit(f"{w} has no {f}: pass workdirs of benchmarks/blind_diagnosis.py "
                                 "(made with --workdir), not reports.")  # fmt: skip
        diagnoses = json.loads((w / "diagnoses.json").read_text())
        key = json.loads((w / "key.json").read_text())
        for case, stored in sorted(diagnoses.items()):
            report = stored.get("report", stored)
            if "verdict" not in report:
                continue  # a case whose diagnosis failed: the draw's report lists it
            truth = key[case]
            head = f"{w.name} {case} {truth['plant']:5s} true {truth['effect']:15s} verdict {report['verdict']:15s}"
            for name, place, cand, cut in small_cut_candidates(report, min_error_ratio):
                det, dbic = cand["detail"], cand["delta_bic_val"]
                if det.get("effect_size_passes") is None:
                    continue  # not tested for size (a draw from before the test)
                p = det.get("p_output_error", cand["train_p"])
                line = (f"{head} {name} #{place} {cand['effect']:10s} cut x{cut:.3f} p {p:.1e} "
                        f"dBIC_val {dbic:.2f} z {cand['z_score']:.2f}")  # fmt: skip
                if det["effect_size_passes"]:
                    sized.append(f"{line} beats_noise {cand['beats_noise']}")
                elif det.get("acts_on_held_out") == 1.0 and -level <= dbic < 0.0:
                    refused.append(line)
    return sized, refused


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("workdirs", nargs="+", type=Path)
    ap.add_argument("--level", type=float, default=DEFAULTS.held_out_bic,
                    help=f"held_out_bic the draws were diagnosed with ({DEFAULTS.held_out_bic:g})")
    ap.add_argument("--min-error-ratio", type=float, default=DEFAULTS.min_error_ratio,
                    help=f"min_error_ratio ({DEFAULTS.min_error_ratio:g})")
    args = ap.parse_args(argv)
    if args.level < 0:
        ap.error(f"--level is a BIC difference >= 0, got {args.level}")
    sized, refused = audit(args.workdirs, args.level, args.min_error_ratio)
    print(f"sized with a small cut, the amplitude test silent: {len(sized)}", *sized, sep="\n")
    print(f"refused by the level ({args.level:g}): {len(refused)}", *refused, sep="\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
