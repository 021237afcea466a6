"""The Navigator alone (amr_navigation.navigator): who drives each observation, when to plan, goals at any time."""

import numpy as np
import pytest

from amr_navigation.navigator import Controller, Mode, Navigator, Purpose

STRAIGHT = np.array([[0.5, 0.5], [1.5, 0.5], [2.5, 0.5]])


def planned(navigator, decision, path=STRAIGHT, error="", goal_refused=False):
    assert decision.plan is not None, decision
    return navigator.planned(decision.plan, path, error, goal_refused)


def test_explores_until_localized_then_plans_once_and_the_path_follower_drives():
    nav = Navigator((2.5, 0.5))
    first = nav.decide((0.5, 0.5, 0.0), False)
    assert (first.mode, first.controller, first.plan) == (Mode.EXPLORE, Controller.WALL_FOLLOWER, None)
    asked = nav.decide((0.5, 0.5, 0.0), True)
    assert asked.mode is Mode.PLANNING and asked.controller is Controller.NONE and "localized" in asked.events
    assert asked.plan.start == (0.5, 0.5) and asked.plan.goal == (2.5, 0.5) and asked.plan.purpose is Purpose.GOAL
    follow = planned(nav, asked)
    assert follow.mode is Mode.FOLLOW and follow.controller is Controller.PATH_FOLLOWER
    assert follow.path is not None and nav.counters.plans == 1
    again = nav.decide((0.6, 0.52, 0.0), True)
    assert again.plan is None and again.path is None and again.controller is Controller.PATH_FOLLOWER


def test_no_goal_idles_and_a_goal_at_any_time_is_planned_for():
    nav = Navigator()
    idle = nav.decide((0.5, 0.5, 0.0), True)
    assert idle.mode is Mode.IDLE and idle.controller is Controller.NONE and "waiting" in idle.reason
    nav.set_goal((2.5, 0.5))
    follow = planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    assert follow.mode is Mode.FOLLOW
    nav.set_goal((1.5, 0.9))  # before arrival
    asked = nav.decide((1.0, 0.5, 0.0), True)
    assert asked.plan.goal == (1.5, 0.9) and asked.plan.why == "new goal"
    planned(nav, asked, np.array([[1.0, 0.5], [1.5, 0.9]]))
    assert nav.followed(reached=True, replan=False) is None
    reached = nav.decide((1.5, 0.9, 0.0), True)
    assert reached.mode is Mode.REACHED and reached.controller is Controller.NONE
    nav.set_goal((0.5, 0.5))  # after arrival
    assert nav.decide((1.5, 0.9, 0.0), True).plan.goal == (0.5, 0.5)


def test_an_unreachable_new_goal_stops_the_robot_and_says_why_once():
    nav = Navigator((2.5, 0.5))
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    nav.set_goal((2.0, 2.0))
    failed = planned(
        nav, nav.decide((1.0, 0.5, 0.0), True), None, "goal inside an obstacle: (2.0, 2.0) ...", goal_refused=True
    )
    assert failed.mode is Mode.NO_PATH and failed.controller is Controller.NONE and failed.path is None
    assert "no path to (2.00, 2.00): goal inside an obstacle" in failed.reason
    assert nav.followed_path is None  # the old path to the old goal is not driven on
    assert sum("no path" in event for event in failed.events) == 1
    later = nav.decide((1.0, 0.5, 0.0), True)
    assert later.mode is Mode.NO_PATH and later.plan is None and not later.events  # refused goal: no retry, no repeat
    assert nav.goal_refused and len(nav.counters.planning_failures) == 1


def test_a_failure_that_is_not_the_goals_is_retried_and_said_once():
    nav = Navigator((2.5, 0.5))
    first = planned(nav, nav.decide((0.0, 0.5, 0.0), True), None, "start inside an obstacle: ...")
    assert first.mode is Mode.NO_PATH and any("no path" in e for e in first.events)
    retry = nav.decide((0.0, 0.5, 0.0), True)
    assert retry.plan is not None and retry.plan.why == "no path yet"
    second = planned(nav, retry, None, "start inside an obstacle: ...")
    assert second.mode is Mode.NO_PATH and not any("no path" in e for e in second.events)
    assert planned(nav, nav.decide((0.5, 0.5, 0.0), True)).mode is Mode.FOLLOW


def test_strayed_replans_and_a_failed_stray_replan_keeps_following_the_old_path_to_the_same_goal():
    nav = Navigator((2.5, 0.5), replan_distance=0.25)
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    strayed = nav.decide((1.0, 0.9, 0.0), True)
    assert strayed.plan is not None and strayed.plan.why.startswith("strayed 0.40")
    kept = planned(nav, strayed, None, "start inside an obstacle: ...")
    assert kept.mode is Mode.FOLLOW and kept.controller is Controller.PATH_FOLLOWER and kept.path is None
    assert nav.decide((1.0, 0.9, 0.0), True).plan.why == "no path yet"  # tried again


def test_the_followers_request_plans_to_its_paths_end_and_keeps_the_stray_reference():
    nav = Navigator((2.5, 0.5))
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    nav.decide((1.0, 0.55, 0.0), True)
    request = nav.followed(reached=False, replan=True, why="blocked")
    assert request.purpose is Purpose.FOLLOWER and request.start == (1.0, 0.55) and request.goal == (2.5, 0.5)
    detour = np.array([[1.0, 0.55], [1.5, 0.7], [2.5, 0.5]])
    handed = nav.planned(request, detour)
    assert handed.path is detour or np.array_equal(handed.path, detour)
    assert np.array_equal(nav.followed_path, detour) and np.array_equal(nav.planned_path, STRAIGHT)
    assert nav.counters.plans == 2
    assert nav.planned(nav.followed(False, True), None, "unreachable").path is None  # a failed request keeps the path
    assert np.array_equal(nav.followed_path, detour)


def test_a_late_answer_to_the_followers_request_does_not_bring_back_a_goal_that_was_left():
    nav = Navigator((2.5, 0.5))
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    request = nav.followed(reached=False, replan=True, why="blocked")
    nav.set_goal((2.0, 2.0))
    planned(nav, nav.decide((1.0, 0.5, 0.0), True), None, "goal inside an obstacle", goal_refused=True)
    late = nav.planned(request, np.array([[1.0, 0.5], [2.5, 0.5]]))
    assert late.mode is Mode.NO_PATH and late.path is None and nav.followed_path is None


def test_withdrawn_localization_explores_again_and_keeps_the_path():
    nav = Navigator((2.5, 0.5))
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    lost = nav.decide((0.55, 0.5, 0.0), False)
    assert lost.controller is Controller.WALL_FOLLOWER and nav.counters.localization_losses == 1
    back = nav.decide((0.6, 0.5, 0.0), True)
    assert back.controller is Controller.PATH_FOLLOWER and back.plan is None and nav.counters.plans == 1


def test_a_loss_of_localization_after_arrival_pursues_the_goal_again():
    """The robot moved after arrival (kidnapped, a simulator reset): once localized again the goal is planned for."""
    nav = Navigator((2.5, 0.5))
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    nav.followed(reached=True, replan=False)
    assert nav.decide((2.5, 0.5, 0.0), True).mode is Mode.REACHED
    assert nav.decide((2.5, 0.5, 0.0), True).mode is Mode.REACHED, "held while localized"
    assert nav.decide((0.5, 0.5, 0.0), False).controller is Controller.WALL_FOLLOWER
    again = nav.decide((0.5, 0.5, 0.0), True)
    assert again.mode is Mode.PLANNING and again.plan.goal == (2.5, 0.5) and again.plan.start == (0.5, 0.5)
    assert planned(nav, again).mode is Mode.FOLLOW


def test_a_goal_changed_while_planning_is_planned_for_instead():
    nav = Navigator((2.5, 0.5))
    asked = nav.decide((0.5, 0.5, 0.0), True)
    nav.set_goal((1.5, 0.5))
    again = nav.planned(asked.plan, STRAIGHT)
    assert again.plan is not None and again.plan.goal == (1.5, 0.5) and nav.counters.plans == 0


def test_a_path_the_follower_refuses_stops_the_robot():
    nav = Navigator((2.5, 0.5))
    planned(nav, nav.decide((0.5, 0.5, 0.0), True))
    refused = nav.path_refused("a single point")
    assert refused.mode is Mode.NO_PATH and refused.controller is Controller.NONE and "single point" in refused.reason


@pytest.mark.parametrize("goal", [(float("nan"), 0.0), (0.0, float("inf"))])
def test_a_non_finite_goal_is_refused(goal):
    with pytest.raises(ValueError, match="finite"):
        Navigator().set_goal(goal)
