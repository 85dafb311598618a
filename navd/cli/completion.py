"""``navd completion bash|zsh``: shell completion for the command line, made from its parser.

Commands, sub-commands and options complete; anything else falls back to file names (config
files, maps, recordings). Install with ``navd completion bash > /etc/bash_completion.d/navd``
or, for zsh, ``navd completion zsh > "${fpath[1]}/_navd"`` (it uses zsh's bash completion
layer).
"""

from __future__ import annotations

import argparse
import shlex
import sys

from navd.cli.common import EXIT_OK, Commands

__all__ = ["add_commands", "completion_tree", "script"]


def add_commands(commands: Commands) -> None:
    """Add ``completion``."""
    completion = commands.add_parser(
        "completion", help="print the shell completion script (bash or zsh)"
    )
    completion.add_argument("shell", choices=("bash", "zsh"))
    completion.set_defaults(handler=_completion)


def completion_tree(parser: argparse.ArgumentParser) -> dict[str, list[str]]:
    """Per command path (``""``, ``"config"``, ``"config get"``), the words that may follow:
    its sub-commands, or its options."""
    tree: dict[str, list[str]] = {}

    def walk(path: str, node: argparse.ArgumentParser) -> None:
        words: list[str] = []
        for action in node._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, child in action.choices.items():
                    words.append(name)
                    walk(f"{path} {name}".strip(), child)
            elif action.option_strings:
                words += [o for o in action.option_strings if o.startswith("--")]
            elif action.choices:
                words += [str(c) for c in action.choices]
        tree[path] = words

    walk("", parser)
    return tree


def script(shell: str, tree: dict[str, list[str]]) -> str:
    """The completion script for ``shell`` ("bash" or "zsh")."""
    cases = "\n".join(
        f"    {shlex.quote(path)}) words={shlex.quote(' '.join(words))} ;;"
        for path, words in sorted(tree.items())
    )
    known = " ".join(shlex.quote(f"|{path}|") for path in tree)
    body = f"""_navd() {{
  local cur="${{COMP_WORDS[COMP_CWORD]}}" path="" w words=""
  local known=({known})
  for w in "${{COMP_WORDS[@]:1:COMP_CWORD-1}}"; do
    [[ $w == -* ]] && continue
    local next="${{path:+$path }}$w"
    [[ " ${{known[*]}} " == *" |$next| "* ]] && path="$next"
  done
  case "$path" in
{cases}
  esac
  COMPREPLY=($(compgen -W "$words" -- "$cur"))
}}
complete -o default -F _navd navd
"""
    header = "# navd's command line completion (navd completion bash)\n"
    if shell == "zsh":
        header = (
            "#compdef navd\n# navd's command line completion (navd completion zsh)\n"
            "autoload -U +X bashcompinit && bashcompinit\n"
        )
    return header + body


def _completion(args: argparse.Namespace) -> int:
    from navd.cli import _parser  # noqa: PLC0415 - the whole parser, made once asked

    sys.stdout.write(script(args.shell, completion_tree(_parser())))
    return EXIT_OK
