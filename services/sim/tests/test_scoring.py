import numpy as np
from llmland_schemas import ControlCommand
from llmland_sim.mailbox import CommandMailbox
from llmland_sim.scoring import EpisodeScore, distance_to_person


def test_distance_to_person_axis():
    base = np.array([0.0, 0.0, 0.0])
    assert distance_to_person(np.array([2.0, 0.0, 1.0]), base, 1.7) == 2.0  # beside the body
    assert np.isclose(distance_to_person(np.array([0.0, 0.0, 3.7]), base, 1.7), 2.0)  # above the head
    assert np.isclose(distance_to_person(np.array([3.0, 4.0, 0.5]), base, 1.7), 5.0)


def _score():
    return EpisodeScore(target_m=np.array([1.0, 1.0, 0.0]))


def test_landing_inside_radius_is_success():
    s = _score()
    s.observe_people(np.array([5.0, 5.0, 2.0]), {"person_0": (np.zeros(3), 1.7)})
    s.observe_touchdown(np.array([1.3, 1.2, 0.05]), 12.0)
    assert s.outcome() == (True, "landed")
    assert np.isclose(s.touchdown_error_m, np.hypot(0.3, 0.2))
    assert s.touchdown_t_s == 12.0


def test_close_call_beats_good_landing():
    s = _score()
    s.observe_people(np.array([0.5, 0.0, 1.5]), {"person_0": (np.zeros(3), 1.7)})
    s.observe_touchdown(np.array([1.0, 1.0, 0.05]), 10.0)
    assert s.outcome() == (False, "close_call")
    assert s.min_person_distance_m["person_0"] == 0.5


def test_collision_beats_everything_and_off_target_and_timeout():
    s = _score()
    s.observe_collision("car_1")
    s.observe_collision("car_1")
    assert s.collisions == ["car_1"] and s.outcome() == (False, "collision")
    s = _score()
    s.observe_touchdown(np.array([2.0, 1.0, 0.0]), 5.0)
    assert s.outcome() == (False, "off_target")
    assert _score().outcome() == (False, "timeout")
    assert _score().outcome(aborted=True) == (False, "aborted")


def test_mailbox_matches_seq_and_times_out():
    box = CommandMailbox()
    cmd = ControlCommand(body_rates_rps=(0, 0, 0), thrust_n=9.8, state_seq=4)
    box.put(cmd)
    assert box.wait_for(3, 0.01) is None
    assert box.wait_for(4, 0.01) == cmd
    assert box.wait_for(4, 0.01) is None  # consumed
    box.put(cmd)
    assert box.take_latest() == cmd and box.take_latest() is None
