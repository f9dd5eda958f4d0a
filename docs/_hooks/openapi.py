"""MkDocs hook: the HTTP API reference page, rendered from the OpenAPI document the service's app serves.

The document is built offline, in the building process, by ``service.app.create_app(...).openapi()`` (no server
is started: the app's lifespan never runs), so the page always matches the code. The hook appends every
operation and every schema to ``reference/http-api.md`` and adds the document itself as
``reference/openapi.json``.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
PAGE = "reference/http-api.md"
DOCUMENT = "reference/openapi.json"
_cache: dict[str, Any] = {}


def openapi() -> dict[str, Any]:
    """The app's OpenAPI document (the store is a throw-away directory: building the app does not touch it)."""
    if "doc" not in _cache:
        if str(ROOT) not in sys.path:
            sys.path.insert(0, str(ROOT))
        from service.app import create_app
        from service.settings import Settings

        with tempfile.TemporaryDirectory() as store:
            app = create_app(Settings(store_dir=Path(store), sim_workers=0))
            _cache["doc"] = app.openapi()
    return _cache["doc"]


def on_files(files, config):
    files.append(File.generated(config, DOCUMENT, content=json.dumps(openapi(), indent=1)))
    return files


def on_page_markdown(markdown: str, page, config, files):
    if page.file.src_uri != PAGE:
        return markdown
    return markdown.rstrip() + "\n\n" + render(openapi())


# -- rendering ---------------------------------------------------------------------------------------------------

METHODS = ("get", "post", "put", "patch", "delete")


def _anchor(name: str) -> str:
    return "schema-" + name.lower()


def _cell(text: Any) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ").strip()


def _type(schema: dict[str, Any]) -> str:
    """A schema as a short type: a link for a named schema, "list of ...", "A or B"."""
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return f"[`{name}`](#{_anchor(name)})"
    for key in ("anyOf", "oneOf"):
        if key in schema:
            kinds = [_type(s) for s in schema[key]]
            return " or ".join(dict.fromkeys(kinds))
    if "allOf" in schema and len(schema["allOf"]) == 1:
        return _type(schema["allOf"][0])
    if "const" in schema:
        return f"`{json.dumps(schema['const'])}`"
    if "enum" in schema:
        return "one of " + ", ".join(f"`{json.dumps(e)}`" for e in schema["enum"])
    kind = schema.get("type")
    if kind == "array":
        item = _type(schema.get("items", {}))
        size = ""
        if schema.get("minItems") is not None and schema.get("minItems") == schema.get("maxItems"):
            size = f" ({schema['minItems']})"
        return f"list{size} of {item}"
    if kind == "object" and isinstance(schema.get("additionalProperties"), dict):
        return f"object of {_type(schema['additionalProperties'])}"
    if kind == "string" and schema.get("format") == "binary":
        return "bytes"
    return f"{kind}" if kind else "any"


def _body(op: dict[str, Any]) -> list[str]:
    body = op.get("requestBody")
    if not body:
        return []
    lines = []
    for media, content in body.get("content", {}).items():
        schema = content.get("schema", {})
        note = schema.get("description", "")
        lines.append(f"- body, `{media}`: {_type(schema)}" + (f" ({note})" if note else ""))
    for media, content in body.get("content", {}).items():
        if "example" in content:
            example = json.dumps(content["example"])
            lines += ["", f"Example (`{media}`):", "", "```json", example, "```"]
    return lines


def _operation(path: str, method: str, op: dict[str, Any]) -> list[str]:
    lines = [f"### `{method.upper()} {path}`", ""]
    if op.get("summary"):
        lines += [op["summary"] + ("." if not op["summary"].endswith(".") else ""), ""]
    if op.get("description"):
        lines += [op["description"], ""]
    params = op.get("parameters", [])
    if params:
        lines += ["| parameter | in | type | required | description |", "|---|---|---|---|---|"]
        for p in params:
            lines.append(f"| `{p['name']}` | {p['in']} | {_type(p.get('schema', {}))} | "
                         f"{'yes' if p.get('required') else 'no'} | {_cell(p.get('description', ''))} |")
        lines.append("")
    lines += _body(op)
    lines += ["", "| answer | content |", "|---|---|"]
    for status, answer in op.get("responses", {}).items():
        kinds = [f"`{media}` {_type(c.get('schema', {}))}" if c.get("schema") else f"`{media}`"
                 for media, c in answer.get("content", {}).items()]
        lines.append(f"| {status} {_cell(answer.get('description', ''))} | {_cell(', '.join(kinds)) or '-'} |")
    return lines + [""]


def _schema(name: str, schema: dict[str, Any]) -> list[str]:
    lines = [f"### `{name}` {{#{_anchor(name)}}}", ""]
    if schema.get("description"):
        lines += [schema["description"], ""]
    props = schema.get("properties", {})
    if props:
        required = set(schema.get("required", []))
        lines += ["| field | type | required | description |", "|---|---|---|---|"]
        for field, sub in props.items():
            need = "yes" if field in required else (f"no (default `{json.dumps(sub['default'])}`)"
                                                     if "default" in sub and sub["default"] is not None else "no")
            lines.append(f"| `{field}` | {_cell(_type(sub))} | {_cell(need)} | {_cell(sub.get('description', ''))} |")
        lines.append("")
    elif "enum" in schema or "anyOf" in schema or "type" in schema:
        lines += [f"Type: {_type(schema)}", ""]
    if schema.get("additionalProperties") is False:
        lines += ["Other fields are refused (422, naming the field and the fields expected).", ""]
    return lines


def render(doc: dict[str, Any]) -> str:
    lines = [f"Document version {doc['info'].get('version', '')}, OpenAPI {doc.get('openapi', '')}.", "",
             "## Operations", ""]
    for path, item in doc.get("paths", {}).items():
        for method in METHODS:
            if method in item:
                lines += _operation(path, method, item[method])
    lines += ["## Schemas", ""]
    for name, schema in sorted(doc.get("components", {}).get("schemas", {}).items()):
        lines += _schema(name, schema)
    return "\n".join(lines) + "\n"
