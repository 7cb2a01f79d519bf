"""``report.md`` of a discovery run: what the model was missing, where, and the proof."""
from __future__ import annotations

from typing import Any, Mapping

import pandas as pd

from nlupdate.reporting.markdown import markdown_table, number, run_line


def discovery_markdown(result, manifest: Mapping[str, Any]) -> str:
    """The report of a :class:`~nlupdate.core.discovery.workflow.DiscoveryResult`."""
    lines = [f"# Discovery: `{manifest['inputs']['model']['file']}` against `{manifest['inputs']['measured']['file']}`", "",
             run_line(manifest), "", "## Summary", ""]
    if result.effects:
        for i, effect in enumerate(result.effects, start=1):
            values = ", ".join(f"{k} = {number(v)}" for k, v in effect.parameters.items())
            lines.append(f"{i}. **{effect.name}** on {result.place(effect.dofs)}: {values}")
    else:
        lines.append("**none**: no effect of the library explains the disagreement significantly better than the "
                     "measurement noise; the model is left unchanged.")
    fit = result.summary()
    lines += ["", f"**{fit}**." if result.fit == "poor" else f"{fit[0].upper()}{fit[1:]}.", "",
              f"Gap (mean over force levels of 1 − FRAC): before **{number(result.gap_before.gap, 3)}**, after "
              f"**{number(result.gap_after.gap, 3)}**; stopped: {result.stop_reason}.", ""]
    if result.warnings:
        lines += ["Warnings (results not to be taken as they stand):", ""]
        lines += [f"* {warning}" for warning in result.warnings] + [""]
    reasoning = [(s.iteration, text) for s in result.steps for text in s.changes]
    reasoning += [(c.iteration, c.equivalent.describe(c.dofs, result.system.model.dof_names)) for s in result.steps for c in s.candidates
                  if c.equivalent is not None and c is s.candidates[0]]
    reasoning += [(0, text) for text in result.restarts]
    if reasoning:
        lines += ["Reconsidered on the way:", ""] + [f"* {f'iteration {i}: ' if i else ''}{text}" for i, text in sorted(reasoning)] + [""]
    lines += ["## Gap per force level", ""]
    rows = [{"force (N)": b.force_n, "gap before": b.gap, "gap after": a.gap, "resonance shift before (%)":
             b.resonance_shift_percent, "after (%)": a.resonance_shift_percent, "unsolved points after":
             a.unsolved_points, "points on another branch than the sweep": a.other_branch_points}
            for b, a in zip(result.gap_before.levels, result.gap_after.levels)]
    lines += [markdown_table(pd.DataFrame(rows), 3), "", "![gap per level](gap_per_level.png)", "",
              "![measured vs before vs after](frf_levels.png)", "",
              "![residual against amplitude](residual_amplitude.png)", "",
              "![describing function vs candidates](describing_function.png)", "",
              "## Files", "", "* `discovery.json` — effects, every candidate with its score, gaps, steps",
              "* `augmented_model.toml` — the model with the effects added (every command loads it)",
              "* `model.toml`, `measured.parquet` — the inputs as run; `manifest.json` — hashes, versions, timing", ""]
    return "\n".join(lines)
