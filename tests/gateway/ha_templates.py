"""The part of Jinja that the gateway's Home Assistant templates use, evaluated the way Home
Assistant renders an MQTT value template (jinja2 is no dependency of the tests): ``{{ ... }}``
around an expression of ``value_json`` (the message's JSON), attributes (``.state``) and
items (``["main"]``), string, number and dict literals, ``none``/``true``/``false``, ``x if
c else y``, ``and``/``or``/``not``, ``==``/``!=``, ``is none``/``is not none``, a dict's
``.get(key)``, and the filters ``bitwise_and(n)`` and ``tojson`` (Home Assistant's).

Strict where Jinja would only warn: a name, attribute or item that is not there raises
`Undefined` (Home Assistant logs an error for every message that makes a template use one),
and so does any part of the language beyond this subset (`TemplateError`), so a template the
gateway starts to publish with more of Jinja fails its test instead of being checked loosely.

`render(template, payload)` returns the text Home Assistant would get: ``None`` renders as
``None`` (which Home Assistant's sensors, binary sensors, switches and numbers take for
"unknown"), ``True`` as ``True``, numbers as Python writes them."""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Callable
from typing import Any

Thunk = Callable[[], Any]
"""What evaluates a part of an expression."""

TOKEN = re.compile(
    r"""\s*(?:(?P<number>-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?)"""
    r"""|(?P<string>"(?:[^"\\]|\\.)*"|'(?:[^'\\]|\\.)*')"""
    r"""|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"""
    r"""|(?P<op>==|!=|[.\[\]():,{}|]))"""
)
KEYWORDS = {"if", "else", "and", "or", "not", "is"}
CONSTANTS = {"none": None, "None": None, "true": True, "True": True, "false": False}
CONSTANTS["False"] = False


class TemplateError(Exception):
    """The template is beyond the subset this evaluator knows."""


class Undefined(Exception):
    """The template uses a name, attribute or item the message does not have."""


def _tokens(text: str) -> list[tuple[str, str]]:
    found = []
    at = 0
    text = text.rstrip()
    while at < len(text):
        match = TOKEN.match(text, at)
        if match is None or match.end() == at:
            raise TemplateError(f"cannot read {text[at:]!r}")
        kind = match.lastgroup
        assert kind is not None
        found.append((kind, match.group(kind)))
        at = match.end()
    return found


class _Parser:
    def __init__(self, text: str, value_json: Any) -> None:
        self.tokens = _tokens(text)
        self.at = 0
        self.value_json = value_json

    # -- tokens ------------------------------------------------------------------------------
    def peek(self) -> tuple[str, str] | None:
        return self.tokens[self.at] if self.at < len(self.tokens) else None

    def take(self, value: str | None = None) -> tuple[str, str]:
        token = self.peek()
        if token is None or (value is not None and token[1] != value):
            raise TemplateError(f"expected {value or 'more'}, found {token}")
        self.at += 1
        return token

    def sees(self, value: str) -> bool:
        token = self.peek()
        return token is not None and token[1] == value and token[0] in ("op", "name")

    # -- grammar: each rule returns what evaluates its part, so that only the branch of
    # ``x if c else y`` that is taken, and of ``and``/``or`` what is needed, is evaluated
    def expression(self) -> Thunk:
        value = self.either()
        if self.sees("if"):
            self.take("if")
            condition = self.either()
            self.take("else")
            otherwise = self.expression()
            return lambda: value() if condition() else otherwise()
        return value

    def either(self) -> Thunk:
        value = self.both()
        while self.sees("or"):
            self.take("or")
            left, right = value, self.both()
            value = lambda left=left, right=right: left() or right()  # noqa: E731
        return value

    def both(self) -> Thunk:
        value = self.negation()
        while self.sees("and"):
            self.take("and")
            left, right = value, self.negation()
            value = lambda left=left, right=right: left() and right()  # noqa: E731
        return value

    def negation(self) -> Thunk:
        if self.sees("not"):
            self.take("not")
            inner = self.negation()
            return lambda: not inner()
        return self.comparison()

    def comparison(self) -> Thunk:
        value = self.filtered()
        while True:
            left = value
            if self.sees("is"):
                self.take("is")
                negated = self.sees("not")
                if negated:
                    self.take("not")
                test = self.take()[1]
                if test != "none":
                    raise TemplateError(f"test {test!r}")
                value = lambda left=left, negated=negated: (left() is None) != negated  # noqa: E731
            elif self.sees("==") or self.sees("!="):
                equal = self.take()[1] == "=="
                right = self.filtered()
                value = lambda left=left, right=right, equal=equal: (left() == right()) == equal  # noqa: E731
            else:
                return value

    def filtered(self) -> Thunk:
        value = self.postfix()
        while self.sees("|"):
            self.take("|")
            name = self.take()[1]
            args = self.arguments() if self.sees("(") else []
            if name == "bitwise_and" and len(args) == 1:
                value = lambda inner=value, mask=args[0]: _bitwise_and(inner(), mask())  # noqa: E731
            elif name == "tojson" and not args:
                value = lambda inner=value: json.dumps(inner())  # noqa: E731
            else:
                raise TemplateError(f"filter {name!r}")
        return value

    def arguments(self) -> list[Thunk]:
        self.take("(")
        args = []
        while not self.sees(")"):
            args.append(self.expression())
            if not self.sees(")"):
                self.take(",")
        self.take(")")
        return args

    def postfix(self) -> Thunk:
        value = self.primary()
        while True:
            inner = value
            if self.sees("."):
                self.take(".")
                name = self.take()[1]
                if name == "get" and self.sees("("):
                    args = self.arguments()
                    value = lambda inner=inner, args=args: _get(inner(), [a() for a in args])  # noqa: E731
                else:
                    value = lambda inner=inner, name=name: _item(inner(), name)  # noqa: E731
            elif self.sees("["):
                self.take("[")
                key = self.expression()
                self.take("]")
                value = lambda inner=inner, key=key: _item(inner(), key())  # noqa: E731
            else:
                return value

    def primary(self) -> Thunk:
        kind, text = self.take()
        if kind == "number":
            number = float(text) if any(c in text for c in ".eE") else int(text)
            return lambda: number
        if kind == "string":
            literal = ast.literal_eval(text)
            return lambda: literal
        if kind == "name":
            if text in CONSTANTS:
                constant = CONSTANTS[text]
                return lambda: constant
            if text == "value_json":
                return lambda: self.value_json
            if text in KEYWORDS:
                raise TemplateError(f"{text!r} where a value belongs")
            raise Undefined(f"no variable {text!r}")
        if text == "(":
            value = self.expression()
            self.take(")")
            return value
        if text == "{":
            pairs = []
            while not self.sees("}"):
                key = self.expression()
                self.take(":")
                pairs.append((key, self.expression()))
                if not self.sees("}"):
                    self.take(",")
            self.take("}")
            return lambda: {key(): value() for key, value in pairs}
        raise TemplateError(f"unexpected {text!r}")


def _bitwise_and(value: Any, mask: Any) -> int:
    if not isinstance(value, int) or not isinstance(mask, int):
        raise TemplateError(f"bitwise_and of {value!r} and {mask!r}")
    return value & mask


def _get(value: Any, args: list[Any]) -> Any:
    if not isinstance(value, dict) or not 1 <= len(args) <= 2:
        raise TemplateError(f".get{tuple(args)!r} of {value!r}")
    return value.get(*args)


def _item(value: Any, key: Any) -> Any:
    if isinstance(value, dict) and key in value:
        return value[key]
    raise Undefined(f"{key!r} is not in {json.dumps(value)[:120]}")


def render(template: str, payload: bytes | str) -> str:
    """``template`` rendered with the JSON of ``payload`` as ``value_json``; `Undefined` if
    it uses what the message does not have, `TemplateError` if it is no template of the
    subset."""
    value_json = json.loads(payload)
    if "{%" in template or "{#" in template:
        raise TemplateError(f"statements and comments are beyond the subset: {template!r}")
    out = []
    rest = template
    while rest:
        start = rest.find("{{")
        if start < 0:
            out.append(rest)
            break
        end = rest.find("}}", start)
        if end < 0:
            raise TemplateError(f"unclosed expression in {template!r}")
        out.append(rest[:start])
        parser = _Parser(rest[start + 2 : end], value_json)
        value = parser.expression()
        if parser.peek() is not None:
            raise TemplateError(f"left over: {parser.tokens[parser.at :]}")
        out.append(str(value()))
        rest = rest[end + 2 :]
    return "".join(out)
