"""Shell completion: the script bash runs completes commands, sub-commands and options."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from navd.cli import _parser
from navd.cli.completion import completion_tree, script


def _complete(line: str, shell_script: str) -> list[str]:
    """What bash offers for ``line`` (the cursor at its end), with navd's script loaded."""
    words = line.split(" ")
    probe = (
        f"{shell_script}\n"
        f"COMP_WORDS=({' '.join(repr(w) for w in words)}); COMP_CWORD={len(words) - 1}\n"
        "_navd; printf '%s\\n' \"${COMPREPLY[@]}\"\n"
    )
    done = subprocess.run(
        ["bash", "--norc", "-c", probe], capture_output=True, text=True, check=True
    )
    return done.stdout.split()


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash is not installed")
def test_bash_completes_commands_sub_commands_and_options() -> None:
    bash = script("bash", completion_tree(_parser()))
    assert _complete("navd con", bash) == ["config"]
    assert _complete("navd config ", bash) == ["--help", "check", "dump", "get", "set"]
    assert _complete("navd config get --p", bash) == ["--port"]
    assert _complete("navd goal 1 2 --w", bash) == ["--wait"]  # positionals are skipped
    assert _complete("navd completion z", bash) == ["zsh"]
    # an unknown word (a positional, a typo) leaves the completion where it was
    assert _complete("navd nosuch ", bash) == _complete("navd ", bash)


def test_every_command_of_the_parser_is_in_the_tree() -> None:
    tree = completion_tree(_parser())
    assert {"run", "config get", "map save", "pose set", "teleop", "replay"} <= tree.keys()
    assert "--record" in tree["run"] and "--session" in tree["replay"]


def test_the_zsh_script_loads_bash_completion_first() -> None:
    zsh = script("zsh", completion_tree(_parser()))
    assert zsh.startswith("#compdef navd\n") and "bashcompinit" in zsh.splitlines()[2]


def test_navd_completion_prints_the_script() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "navd", "completion", "bash"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "complete -o default -F _navd navd" in done.stdout
