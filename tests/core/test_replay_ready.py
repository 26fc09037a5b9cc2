"""A replay gives every output its chance to link before the first record."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from core_dummies import ListOutput

from edged.cli import build_parser
from edged.commands import dispatch


class SlowToLink(ListOutput):
    """Links after a few loop turns; says whether the first record came after that."""

    linked_after: int = 3
    answer: bool = True

    async def ready(self, timeout: float | None = None) -> bool:
        self.events.append("ready?")
        for _ in range(self.linked_after):
            await asyncio.sleep(0)
        self.events.append("ready")
        return self.answer

    def write(self, batch: list[Any]) -> None:
        if "first-write" not in self.events:
            self.events.append("first-write")
        super().write(batch)


def _replay(registry, tmp_path: Path, answer: bool) -> SlowToLink:
    SlowToLink.answer = answer
    registry.register("outputs", "slow", SlowToLink)
    log = tmp_path / "gyro.log"
    log.write_text("#dummy\n1.0 yaw_rate r=1\n2.0 yaw_rate r=2\n")
    cfg = tmp_path / "c.toml"
    cfg.write_text('[outputs.pub]\ntype = "slow"\n')
    ListOutput.instances.clear()
    args = build_parser().parse_args(["replay", str(log), "-c", str(cfg), "--no-zenoh", "--no-progress"])
    assert dispatch(args, registry) == 0
    return ListOutput.instances[0]  # type: ignore[return-value]


def test_the_first_record_waits_until_the_output_is_linked(registry, tmp_path):
    out = _replay(registry, tmp_path, True)
    assert out.events.index("ready") < out.events.index("first-write")
    assert "not_ready_at_start" not in out.ctx.health.counters


def test_an_output_not_linked_in_time_is_counted_and_the_replay_goes_on(registry, tmp_path, caplog):
    out = _replay(registry, tmp_path, False)
    assert out.ctx.health.counters["not_ready_at_start"] == 1
    assert len([r for r in out.records if getattr(r, "kind", None) == "yaw_rate"]) == 2
