"""Policy keyword arguments of the agent configs: checked names in, SB3 objects out.

Two spellings are accepted for ``policy_kwargs``:

* a mapping (``activation_fn: tanh``, ``net_arch: {pi: [64, 64], vf: [64, 64]}``);
* the rl-baselines3-zoo string ``"dict(activation_fn=nn.Tanh, net_arch=dict(pi=[64, 64]))"``,
  parsed with :mod:`ast` (literals, ``dict(...)`` and ``nn.<Activation>`` only; nothing is
  evaluated).

:func:`policy_kwargs_object` turns the checked mapping into what SB3's policies take.
"""

from __future__ import annotations

import ast
from typing import Any, Mapping

__all__ = ["ACTIVATIONS", "parse_policy_kwargs", "policy_kwargs_object"]

#: activation names and their torch.nn classes (zoo spelling ``nn.Tanh`` -> ``tanh``)
ACTIVATIONS: dict[str, str] = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU",
                               "gelu": "GELU", "silu": "SiLU"}
_BY_CLASS = {v: k for k, v in ACTIVATIONS.items()}


def _literal(node: ast.AST, where: str) -> Any:
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
        return {kw.arg: _literal(kw.value, where) for kw in node.keywords}
    if isinstance(node, ast.Dict):
        return {_literal(k, where): _literal(v, where) for k, v in zip(node.keys, node.values)}
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_literal(e, where) for e in node.elts]
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in ("nn", "th.nn", "torch"):
        if node.attr not in _BY_CLASS:
            raise ValueError(f"{where}: activation nn.{node.attr}; allowed nn.{', nn.'.join(_BY_CLASS)}")
        return _BY_CLASS[node.attr]
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return -_literal(node.operand, where)
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float, bool, str)):
        return node.value
    raise ValueError(f"{where}: unsupported expression {ast.unparse(node)!r} (literals, dict(...), nn.<Activation>)")


def parse_policy_kwargs(value: Any, where: str = "policy_kwargs") -> dict[str, Any]:
    """``policy_kwargs`` as a plain mapping, from a mapping or the zoo's ``dict(...)`` string."""
    if value is None:
        return {}
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, str):
        try:
            tree = ast.parse(value.strip(), mode="eval")
        except SyntaxError as e:
            raise ValueError(f"{where}: {value!r} is not a dict(...) expression ({e.msg})") from None
        out = _literal(tree.body, where)
        if not isinstance(out, dict):
            raise ValueError(f"{where}: {value!r} must be dict(...)")
        return out
    raise ValueError(f"{where}: expected a mapping or a 'dict(...)' string, got {value!r}")


def policy_kwargs_object(pk: Mapping[str, Any]) -> dict[str, Any]:
    """The checked mapping with ``activation_fn`` as its torch class and ``net_arch`` lists."""
    import torch.nn as nn

    out = dict(pk)
    if "activation_fn" in out:
        out["activation_fn"] = getattr(nn, ACTIVATIONS[out["activation_fn"]])
    if isinstance(out.get("net_arch"), dict):
        out["net_arch"] = {k: list(v) for k, v in out["net_arch"].items()}
    return out
