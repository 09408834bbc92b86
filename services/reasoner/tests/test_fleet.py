"""The fleet queue: the newest scene of each drone wins, and no drone is starved."""

from __future__ import annotations

import threading

from llmland_reasoner.fleet import FairSceneQueue


def test_newest_scene_per_drone_wins_and_superseded_are_counted() -> None:
    q: FairSceneQueue[int] = FairSceneQueue()
    for seq in range(5):
        q.put("d0", seq)
    q.put("d1", 100)
    got = q.take(10, timeout_s=0.1)
    assert [(p.drone, p.item) for p in got] == [("d0", 4), ("d1", 100)]
    assert q.offered == {"d0": 5, "d1": 1} and q.superseded == {"d0": 4}
    assert q.take(10, timeout_s=0.01) == []


def test_a_chatty_drone_cannot_starve_a_quiet_one() -> None:
    q: FairSceneQueue[int] = FairSceneQueue()
    order: list[str] = []
    for rnd in range(20):  # d0 publishes 5 scenes a round, d1 one; the server takes one a round
        for k in range(5):
            q.put("d0", 5 * rnd + k)
        q.put("d1", rnd)
        (p,) = q.take(1, timeout_s=0.1)
        order.append(p.drone)
        if p.drone == "d0":
            assert p.item == 5 * rnd + 4  # the newest
    assert order == ["d0", "d1"] * 10  # a replaced scene keeps its drone's place in line


def test_round_robin_over_ten_drones_bounds_every_wait() -> None:
    q: FairSceneQueue[int] = FairSceneQueue()
    drones = [f"d{i}" for i in range(10)]
    last: dict[str, int] = dict.fromkeys(drones, -1)
    for rnd in range(30):
        for d in drones if rnd % 2 == 0 else reversed(drones):
            q.put(d, rnd)
        for p in q.take(3, timeout_s=0.1):  # the server takes fewer than are offered each round
            assert p.item == rnd  # always the newest scene
            assert rnd - last[p.drone] <= 4  # ceil(10 / 3) rounds at most between two serves
            last[p.drone] = rnd
    assert all(rnd - last[d] <= 4 for d in drones)


def test_batch_respects_the_cost_budget_but_always_takes_one() -> None:
    q: FairSceneQueue[int] = FairSceneQueue()
    for d, cost in (("a", 5), ("b", 1), ("c", 2)):
        q.put(d, cost)
    assert [p.drone for p in q.take(10, 0.1, cost=lambda c: c, budget=4)] == ["a"]  # over budget alone
    assert [p.drone for p in q.take(10, 0.1, cost=lambda c: c, budget=4)] == ["b", "c"]


def test_drop_and_close_wake_a_waiting_taker() -> None:
    q: FairSceneQueue[int] = FairSceneQueue()
    q.put("d0", 1)
    assert q.drop("d0") and not q.drop("d0") and q.superseded["d0"] == 1
    out: list[object] = []
    t = threading.Thread(target=lambda: out.append(q.take(1, timeout_s=5.0)))
    t.start()
    q.close()
    t.join(timeout=2.0)
    assert not t.is_alive() and out == [[]]


def test_scenes_ready_while_waiting_are_taken_without_waiting() -> None:
    q: FairSceneQueue[int] = FairSceneQueue()
    for d, item in (("a", 1), ("b", 2), ("c", 3), ("d", 4)):
        q.put(d, item)
    assert [p.drone for p in q.take_ready(lambda x: x % 2 == 0)] == ["b", "d"]
    assert q.pending() == ["a", "c"] and q.take_ready(lambda x: False) == []
