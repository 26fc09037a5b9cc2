"""Loss the Zenoh output must show (issue 10): a client whose router goes away counts
what it cannot send and says that its link is down; a replay waits for its link
(`ready`) so that a subscriber gets every sample."""

from __future__ import annotations

import asyncio
from typing import Any, Callable

import pytest
import zenoh

from edged.records import Estimate
from edged_zenoh.output import ROUTE_CHECK_INTERVAL, ZenohOutput, ZenohOutputConfig

T0 = 1_732_350_000.0
SAFETY = 30.0


def est(i: int) -> Estimate:
    return Estimate("stw", "stw", T0 + i * 0.1, {"stw": 4.0 + i * 1e-3})


async def until(pred: Callable[[], bool], what: str) -> None:
    """Poll a condition zenoh gives no event for (a link that went or came back)."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + SAFETY
    while not pred():
        if loop.time() > deadline:
            raise AssertionError(f"not within {SAFETY} s: {what}")
        await asyncio.sleep(0.01)


def stop_router(router: Any) -> None:
    """An outage: the router's machine is gone (SIGKILL: no goodbye on the link)."""
    router.proc.kill()
    router.proc.wait(SAFETY)


def client_output(make_ctx, port: int, **extra: Any) -> tuple[ZenohOutput, Any]:
    c = make_ctx("zenoh", "v1")
    cfg = ZenohOutputConfig.model_validate(
        {"type": "zenoh", "mode": "client", "connect": [f"tcp/127.0.0.1:{port}"],
         "retry_initial": 0.05, "retry_max": 0.2, **extra}
    )
    return ZenohOutput(cfg, c.ctx), c


def test_client_router_outage_is_visible_and_unsent_is_counted(make_ctx, free_port, router_proc):
    port = free_port()
    out, c = client_output(make_ctx, port)
    h = c.health
    h.set_state("running")  # as the supervisor does

    async def scenario() -> None:
        router = router_proc(port)
        await asyncio.to_thread(router.expect, lambda s: "listening on" in s)
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        out.write([est(0), est(1)])
        assert h.counters["published"] == 2
        st = out.status()
        assert st["routers"] == 1 and h.info["zenoh"] == "connected" and h.snapshot()["ok"] is True

        await asyncio.to_thread(stop_router, router)
        await until(lambda: out.status().get("routers") == 0, "the client notices its router is gone")
        assert h.info["zenoh"] == "disconnected"
        snap = h.snapshot()
        assert snap["state"] == "disconnected" and snap["ok"] is False
        assert "no router" in snap["last_error"]
        out.write([est(2), est(3), est(4)])  # during the outage
        assert h.counters["published"] == 2
        assert h.counters["unsent.no_route"] == 3
        assert out.latest.matching  # the latest values are still kept for the next query
        assert len(out.latest) == 1

        router = router_proc(port)  # the router comes back on the same port
        await asyncio.to_thread(router.expect, lambda s: "listening on" in s)
        await until(lambda: out.status().get("routers") == 1, "the client reconnects to its router")
        assert h.info["zenoh"] == "connected"
        snap = h.snapshot()
        assert snap["state"] == "running" and snap["ok"] is True
        out.write([est(5)])
        assert h.counters["published"] == 3 and h.counters["unsent.no_route"] == 3
        await out.close()
        await asyncio.to_thread(stop_router, router)

    asyncio.run(scenario())


def test_write_looks_at_the_router_at_most_every_interval(make_ctx, free_port, router_proc):
    """Between status() calls, write notices a lost router within ROUTE_CHECK_INTERVAL
    of the clock's monotonic time, without asking zenoh for every batch."""
    port = free_port()
    out, c = client_output(make_ctx, port)
    h = c.health

    async def scenario() -> None:
        router = router_proc(port)
        await asyncio.to_thread(router.expect, lambda s: "listening on" in s)
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)
        session = out._session
        assert session is not None
        await asyncio.to_thread(stop_router, router)
        await until(lambda: not list(session.info.routers_zid()), "the router is gone")
        out.write([est(0)])  # the count looked at on open is still trusted
        assert h.counters.get("published") == 1 and "unsent.no_route" not in h.counters
        c.clock.step(ROUTE_CHECK_INTERVAL)
        out.write([est(1)])
        assert h.counters["unsent.no_route"] == 1 and h.info["zenoh"] == "disconnected"
        await out.close()

    asyncio.run(scenario())


def test_client_without_router_is_not_ok_before_the_session_opens(make_ctx, free_port):
    out, c = client_output(make_ctx, free_port())
    c.health.set_state("running")

    async def scenario() -> None:
        await out.open()
        out.status()
        assert c.health.snapshot()["ok"] is False and c.health.state == "disconnected"
        await out.close()

    asyncio.run(scenario())


# -- ready(): a replay waits for its link ---------------------------------------------
def test_ready_times_out_without_router_then_returns_once_it_is_there(make_ctx, free_port, router_proc):
    port = free_port()
    out, c = client_output(make_ctx, port, replay_wait=0.2)

    async def scenario() -> None:
        await out.open()
        assert await out.ready() is False  # replay_wait: bounded, the replay goes on
        assert await out.ready(0) is False
        router = router_proc(port)
        await asyncio.to_thread(router.expect, lambda s: "listening on" in s)
        assert await out.ready(SAFETY) is True
        assert c.health.info["zenoh"] == "connected"
        assert await out.ready(0) is True  # linked: no wait at all
        await out.close()
        await asyncio.to_thread(stop_router, router)

    asyncio.run(scenario())


def test_ready_before_open_includes_the_opening(make_ctx, free_port):
    """A peer listening without connect endpoints is linked as soon as it is open."""
    c = make_ctx("zenoh", "v1")
    out = ZenohOutput(ZenohOutputConfig.model_validate({"type": "zenoh", "listen": [f"tcp/127.0.0.1:{free_port()}"]}), c.ctx)

    async def scenario() -> None:
        waiting = asyncio.create_task(out.ready(SAFETY))
        await asyncio.sleep(0)
        assert not waiting.done()
        await out.open()
        assert await waiting is True
        await out.close()

    asyncio.run(scenario())


def test_replay_wait_is_configurable_and_bounded():
    assert ZenohOutputConfig.model_validate({"type": "zenoh"}).replay_wait == 5.0
    assert ZenohOutputConfig.model_validate({"type": "zenoh", "replay_wait": 0}).replay_wait == 0
    for bad in (-1, float("inf"), float("nan")):
        with pytest.raises(ValueError):
            ZenohOutputConfig.model_validate({"type": "zenoh", "replay_wait": bad})


N = 2000  # samples written at once after ready(), as a replay at full speed does


def _receive_all(sub: Any, prefix: str) -> int:
    last = f'"t":{round(T0 + (N - 1) * 0.1, 3)},'
    n = 0
    while True:
        line = sub.expect(lambda s: s.startswith(f"sample {prefix}/est/stw "))
        n += 1
        if last in line:
            return n


def test_client_replay_after_ready_loses_nothing(make_ctx, free_port, router_proc, zpeer):
    port = free_port()
    out, c = client_output(make_ctx, port, congestion_control="block")

    async def scenario() -> None:
        router = router_proc(port)
        await asyncio.to_thread(router.expect, lambda s: "listening on" in s)
        sub = zpeer("--prefix", "vessel/v1", "--mode", "client", "--connect", f"tcp/127.0.0.1:{port}", "--no-wait-alive")
        await asyncio.to_thread(sub.expect, lambda s: s == "ready")
        await out.open()  # what a replay does: open, then (new) wait for the link ...
        assert await out.ready(SAFETY) is True
        for i in range(0, N, 100):  # ... then publish as fast as it can
            out.write([est(j) for j in range(i, i + 100)])
        assert c.health.counters["published"] == N
        assert "unsent.no_session" not in c.health.counters
        assert await asyncio.to_thread(_receive_all, sub, "vessel/v1") == N
        await out.close()
        await asyncio.to_thread(stop_router, router)

    asyncio.run(scenario())


def test_peer_replay_waits_for_its_connect_peer(make_ctx, free_port, zpeer):
    peer_port = free_port()
    sub = zpeer("--prefix", "vessel/p1", "--listen", f"tcp/127.0.0.1:{peer_port}", "--no-wait-alive")
    sub.expect(lambda s: s == "ready")
    c = make_ctx("zenoh", "p1")
    out = ZenohOutput(ZenohOutputConfig.model_validate(
        {"type": "zenoh", "listen": [f"tcp/127.0.0.1:{free_port()}"], "connect": [f"tcp/127.0.0.1:{peer_port}"],
         "congestion_control": "block"}
    ), c.ctx)

    async def scenario() -> None:
        await out.open()
        assert await out.ready(SAFETY) is True
        assert out.status()["peers"] == 1
        for i in range(0, N, 100):
            out.write([est(j) for j in range(i, i + 100)])
        assert c.health.counters["published"] == N
        assert await asyncio.to_thread(_receive_all, sub, "vessel/p1") == N
        await out.close()

    asyncio.run(scenario())


def test_peer_with_a_dead_connect_endpoint_is_not_ready(make_ctx, free_port):
    c = make_ctx("zenoh", "p2")
    out = ZenohOutput(ZenohOutputConfig.model_validate(
        {"type": "zenoh", "listen": [f"tcp/127.0.0.1:{free_port()}"], "connect": [f"tcp/127.0.0.1:{free_port()}"]}
    ), c.ctx)

    async def scenario() -> None:
        await out.open()
        await asyncio.wait_for(out.connected.wait(), SAFETY)  # open, linked to nobody
        assert await out.ready(0.2) is False
        out.write([est(0)])  # a peer publishes to whoever is there: not a loss
        assert c.health.counters["published"] == 1
        await out.close()

    asyncio.run(scenario())


def test_congestion_control_blocks_in_replay_and_drops_live(make_ctx):
    """A burst of a replay is back-pressured, not dropped at a full send queue; live
    samples never make the event loop wait."""
    cfg = ZenohOutputConfig.model_validate({"type": "zenoh"})
    live = ZenohOutput(cfg, make_ctx("zenoh", "v1").ctx)
    replay = ZenohOutput(cfg, make_ctx("zenoh", "v1", {"replay": True}).ctx)
    forced = ZenohOutput(cfg.model_copy(update={"congestion_control": "block"}), make_ctx("zenoh", "v1").ctx)
    assert live._congestion == zenoh.CongestionControl.DROP
    assert replay._congestion == zenoh.CongestionControl.BLOCK
    assert forced._congestion == zenoh.CongestionControl.BLOCK
    with pytest.raises(ValueError):
        ZenohOutputConfig.model_validate({"type": "zenoh", "congestion_control": "maybe"})
