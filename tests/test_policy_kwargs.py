"""policy_kwargs in both spellings: the project's mapping and the rl-baselines3-zoo string."""

import pytest

from agents.policy_kwargs import parse_policy_kwargs, policy_kwargs_object


def test_zoo_string_and_mapping_give_the_same_kwargs():
    zoo = "dict(log_std_init=-1.0, ortho_init=True, activation_fn=nn.Tanh, net_arch=dict(pi=[64, 64], vf=[64, 64]))"
    mapping = {"log_std_init": -1.0, "ortho_init": True, "activation_fn": "tanh",
               "net_arch": {"pi": [64, 64], "vf": [64, 64]}}
    assert parse_policy_kwargs(zoo) == mapping == parse_policy_kwargs(mapping)
    import torch.nn as nn

    obj = policy_kwargs_object(parse_policy_kwargs(zoo))
    assert obj["activation_fn"] is nn.Tanh and obj["net_arch"] == {"pi": [64, 64], "vf": [64, 64]}


@pytest.mark.parametrize("bad", ["__import__('os').system('true')", "dict(activation_fn=nn.Identity)",
                                 "dict(x=open('f'))", "[1, 2]", "dict(a=1"])
def test_nothing_is_evaluated_and_bad_strings_say_why(bad):
    with pytest.raises(ValueError, match="policy_kwargs"):
        parse_policy_kwargs(bad)
