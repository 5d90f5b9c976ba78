"""The text formats, TOML and JSON, read into a controller file's fields: UTF-8, the
position of a syntax error, no NaN or infinity, the format's version."""

from __future__ import annotations

import json
import re
import tomllib
from typing import Any

from elab.controllers.file_format import VERSION
from elab.errors import InvalidInput


def utf8_text(data: bytes) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidInput(
            "file", f"byte {exc.start}: {data[exc.start : exc.start + 4]!r}", "UTF-8 text"
        ) from None


def text_fields(data: bytes, fmt: str) -> dict[str, Any]:
    text = utf8_text(data)
    try:
        parsed = tomllib.loads(text) if fmt == "toml" else json.loads(text, parse_constant=_no_nan)
    except tomllib.TOMLDecodeError as exc:
        raise InvalidInput("file", _where(str(exc), text), "valid TOML") from None
    except json.JSONDecodeError as exc:
        raise InvalidInput(
            "file", f"line {exc.lineno}, column {exc.colno}: {exc.msg}", "valid JSON"
        ) from None
    except RecursionError:
        raise InvalidInput("file", "nested too deeply", f"a flat {fmt} file") from None
    except ValueError as exc:  # an integer of more digits than Python converts (4,300)
        raise InvalidInput("file", str(exc)[:80], "numbers of at most 4,300 digits") from None
    if not isinstance(parsed, dict):
        raise InvalidInput("file", type(parsed).__name__, "a table of fields (kind = …)")
    if "version" not in parsed:
        raise InvalidInput("version", None, f"version = {VERSION} (the file format's version)")
    if parsed["version"] != VERSION or isinstance(parsed["version"], bool):
        raise InvalidInput("version", parsed["version"], f"{VERSION}")
    return parsed


def _no_nan(token: str) -> Any:
    raise InvalidInput("file", token, "finite numbers (JSON has no NaN or Infinity)")


def _where(message: str, text: str) -> str:
    """tomllib's message with its position first: 'line 3, column 7: …'."""
    m = re.search(r"\(at line (\d+), column (\d+)\)", message)
    if not m:
        end = message.replace("(at end of document)", "").strip()
        return f"line {text.count(chr(10)) + 1}, the end of the file: {end}"
    return f"line {m.group(1)}, column {m.group(2)}: {message[: m.start()].strip()}"
