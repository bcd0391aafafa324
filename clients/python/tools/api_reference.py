#!/usr/bin/python3
"""Writes the chromosphere package's API reference (docs/python-api.md) from
its docstrings and signatures, or with --check exits 1 when the committed page
differs from what the code gives (the test suite runs the check).

    python3 tools/api_reference.py [--check] DOCS/python-api.md   (with the package installed)
"""
import argparse
import dataclasses
import inspect
import sys
from pathlib import Path

import chromosphere  # the installed package (pip install ./clients/python)

HEADER = """# Python package API reference

Generated from the `chromosphere` package's docstrings by
`clients/python/tools/api_reference.py` (the test `python_package` fails
when this page and the code differ; regenerate with
`python3 clients/python/tools/api_reference.py docs/python-api.md` with the
package installed).
How to install and use it: `docs/python.md`.
"""


def doc(obj) -> str:
    return inspect.cleandoc(obj.__doc__ or "").strip()


def render() -> str:
    out = [HEADER]
    for name in chromosphere.__all__:
        obj = getattr(chromosphere, name)
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            continue
        if inspect.isfunction(obj):
            out.append(f"## `{name}{inspect.signature(obj)}`\n\n{doc(obj)}\n")
            continue
        out.append(f"## class `{name}`\n\n{doc(obj)}\n")
        if dataclasses.is_dataclass(obj):
            fields = ", ".join(f"`{f.name}`" for f in dataclasses.fields(obj))
            out.append(f"Fields: {fields}.\n")
        for member, value in obj.__dict__.items():
            if member.startswith("_") and member != "__init__":
                continue
            if isinstance(value, property):
                out.append(f"- `{member}` (property): {doc(value.fget) or '(no docstring)'}")
            elif inspect.isfunction(value):
                if member == "__init__" and dataclasses.is_dataclass(obj):
                    continue
                prefix = "async " if inspect.iscoroutinefunction(value) else ""
                signature = str(inspect.signature(value)).replace("(self, ", "(").replace("(self)", "()")
                fallback = "the constructor (the class's text above)" if member == "__init__" else f"as `Client.{member}`"
                out.append(f"- `{prefix}{member}{signature}`: {doc(value) or fallback}")
        out.append("")
    errors = [n for n in chromosphere.__all__
              if inspect.isclass(getattr(chromosphere, n)) and issubclass(getattr(chromosphere, n), BaseException)]
    out.append("## Errors\n")
    for name in errors:
        out.append(f"- `{name}`: {doc(getattr(chromosphere, name))}")
    return "\n".join(line.replace("\n", " ") if line.startswith("- ") else line for line in out) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--check", action="store_true")
    parser.add_argument("page", type=Path)
    args = parser.parse_args()
    text = render()
    if args.check:
        if not args.page.is_file() or args.page.read_text() != text:
            print(f"{args.page} differs from the package's docstrings; regenerate: "
                  f"python3 clients/python/tools/api_reference.py {args.page}", file=sys.stderr)
            return 1
        return 0
    args.page.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
