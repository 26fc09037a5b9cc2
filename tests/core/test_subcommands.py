"""A plugin's subcommand brings its own arguments (DESIGN §4, `edged.subcommand`)."""

from __future__ import annotations

import argparse
import logging

import pytest

from edged.cli import build_parser
from edged.commands import CORE_COMMANDS, dispatch
from edged.registry import Registry
from edged.subcommand import EXIT_OK, Subcommand


def _hello_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("name")
    p.add_argument("--times", type=int, default=1)


def _registry(**commands: object) -> Registry:
    r = Registry(use_entry_points=False)
    for name, cmd in commands.items():
        r.register("commands", name, cmd)
    return r


def test_a_plugin_command_parses_its_own_arguments_and_runs(capsys):
    said: list[str] = []

    def run(args: argparse.Namespace, registry: Registry) -> int:
        said.extend([args.name] * args.times)
        print("hello", args.name)
        return EXIT_OK

    reg = _registry(hello=Subcommand("say hello", _hello_args, run))
    args = build_parser(["hello", "crew", "--times", "2"], reg).parse_args(["hello", "crew", "--times", "2"])
    assert dispatch(args, reg) == EXIT_OK
    assert said == ["crew", "crew"]
    assert "hello crew" in capsys.readouterr().out


def test_a_plugin_commands_bad_option_is_bad_usage(capsys):
    reg = _registry(hello=Subcommand("say hello", _hello_args, lambda a, r: 0))
    with pytest.raises(SystemExit) as exc:
        build_parser(["hello"], reg).parse_args(["hello", "x", "--times", "many"])
    assert exc.value.code == 2
    assert "--times" in capsys.readouterr().err


def test_only_the_named_command_is_loaded():
    loaded: list[str] = []

    class Counting(Registry):
        def get(self, role, name):
            loaded.append(name)
            return super().get(role, name)

    reg = Counting(use_entry_points=False)
    for name in ("alpha", "beta", "gamma"):
        reg.register("commands", name, Subcommand(name, lambda p: None, lambda a, r: 0))
    build_parser(["beta"], reg)
    assert loaded == ["beta"]
    loaded.clear()
    build_parser((), reg)  # `edged --help`: every one, to list them
    assert loaded == ["alpha", "beta", "gamma"]


def test_a_declaration_that_is_not_a_subcommand_is_left_out_with_a_warning(caplog):
    reg = _registry(broken=lambda args: 0, good=Subcommand("fine", lambda p: None, lambda a, r: 0))
    with caplog.at_level(logging.WARNING, logger="edged"):
        ap = build_parser((), reg)
    choices = next(a for a in ap._actions if isinstance(a, argparse._SubParsersAction)).choices
    assert "good" in choices and "broken" not in choices
    assert "command=broken is not an edged.subcommand.Subcommand" in caplog.text


def test_a_plugin_cannot_take_a_core_commands_name():
    taken: list[str] = []
    reg = _registry(run=Subcommand("not the daemon", lambda p: None, lambda a, r: taken.append("x") or 0))
    args = build_parser(["run", "-c", "x.toml"], reg).parse_args(["run", "-c", "x.toml"])
    assert args.config == "x.toml"  # the core's arguments
    assert CORE_COMMANDS["run"].help == "the daemon (systemd runs this)"


def test_every_installed_first_party_command_is_a_subcommand():
    reg = Registry()
    names = set(reg.names("commands"))
    assert {"demo", "sim", "router", "fleet", "inspect", "export", "plot", "recover", "score"} <= names
    for name in names:
        assert isinstance(reg.get("commands", name), Subcommand), name
