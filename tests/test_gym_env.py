"""The house as a Gymnasium environment (docs/design.md §9.1): the contract, and the fg_tea agent
acting through it writes the same log as the plain runner."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium", reason="the gym extra: pip install -e '.[gym]'")

from fg_tea.episode import gym_env  # noqa: E402
from fg_tea.episode.run import make_env  # noqa: E402
from fg_tea.episode.runner import EpisodeRunner, RunConfig  # noqa: E402
from fg_tea.model.spec import load_model  # noqa: E402
from fg_tea.world.scenario import load_scenario  # noqa: E402


def test_check_env_passes():
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning from the checker either
        check_env(gym_env.TeaEnv(), skip_render_check=True)


def test_gymnasium_make_builds_it_from_a_scenario_and_a_model():
    env = gymnasium.make(f"fg_tea.episode.gym_env:{gym_env.ENV_ID}", scenario="milk_sugar_apartment",
                         model="joint_close")
    obs, info = env.reset(seed=4)
    assert isinstance(env.unwrapped, gym_env.TeaEnv) and env.unwrapped.model.name == "joint_close"
    assert env.observation_space.contains(obs) and info["seed"] == 4
    env.close()


@pytest.mark.parametrize("scenario,model,seed", [("default_apartment", "factorised", 3),
                                                 ("default_apartment", "joint", 1),
                                                 ("generated_small", "factorised_close", 0),
                                                 # the company table goes through the adapter too
                                                 ("default_apartment", "joint_occlusion", 2)])
def test_the_agent_through_gymnasium_writes_the_log_of_fg_tea_run(scenario, model, seed):
    s, m = load_scenario(scenario), load_model(model)
    plain = EpisodeRunner(s, m, make_env(s, m, "fake"), RunConfig(seed=seed))
    plain.run()
    through = EpisodeRunner(s, m, gym_env.GymAdapter(gym_env.TeaEnv(s, m, env="fake")),
                            RunConfig(seed=seed))
    through.run()
    assert through.reason == "complete"
    assert [json.dumps(e) for e in through.events] == [json.dumps(e) for e in plain.events]


def test_random_actions_never_crash_and_the_episode_ends():
    env = gym_env.TeaEnv(max_frames=3000)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    for _ in range(2000):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs) and np.isfinite(reward)
        if terminated or truncated:
            break
    assert terminated or truncated, "3,000 frames end an episode of random actions"


def test_served_tea_terminates_with_the_reward():
    env = gym_env.TeaEnv()
    env.reset(seed=0)
    env.adapter._truth.set("mug", "served", True)  # the world's own truth, set by the test
    _, reward, terminated, _, _ = env.step(env.look("kitchen_counter", ["mug"]))
    assert not terminated and reward <= 0, "a served empty mug is not tea"
    env.adapter._truth.set("mug", "tea_brewed", True)
    _, reward, terminated, _, _ = env.step(env.look("kitchen_counter", ["mug"]))
    assert terminated and reward > 0


def test_without_gymnasium_the_import_is_one_line_naming_the_extra():
    code = ("import sys; sys.modules['gymnasium'] = None\n"
            "try:\n    import fg_tea.episode.gym_env\nexcept Exception as e:\n    print(type(e).__name__, e)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    from fg_tea.common.install import install_command

    assert out.stdout.startswith("InputError") and install_command("gym") in out.stdout
