"""TEMPORARY: the Chapter 6 studies, still written against the old module-level robot and
settings, declared through an adapter until their modules declare ``STUDY`` themselves."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mwip.studies import exp_asta, exp_hodosmc, exp_it2, robot, settings
from mwip.studies.study import Study, StudyContext


def _adapt(fn: Callable[..., dict[str, Any]]) -> Callable[[StudyContext], dict[str, Any]]:
    def run(ctx: StudyContext) -> dict[str, Any]:
        with (
            robot.using(ctx.plant, ctx.nominal, ctx.twin),
            settings.using(ctx.name, dict(ctx.settings)),
        ):
            return fn(ctx.out.parent, quick=ctx.quick)

    return run


STUDIES = (
    Study("exp-hodosmc-balance", exp_hodosmc.SOURCE_BALANCE, _adapt(exp_hodosmc.run_balance),
          place=(6, 4), cost=7),
    Study("exp-hodosmc-speed", exp_hodosmc.SOURCE_SPEED, _adapt(exp_hodosmc.run_speed),
          place=(6, 6), cost=6),
    Study("exp-hodosmc-obstacle", exp_hodosmc.SOURCE_OBSTACLE, _adapt(exp_hodosmc.run_obstacle),
          place=(6, 8), cost=6),
    Study("exp-asta", exp_asta.SOURCE, _adapt(exp_asta.run), place=(6, 9), cost=5),
    Study("exp-it2", exp_it2.SOURCE, _adapt(exp_it2.run), place=(6, 17), cost=7),
)  # fmt: skip
