"""Write ``nfex_client/schema.py``, the client's response types, from the service's OpenAPI document.

    python -m nfex_client.generate http://127.0.0.1:8000/openapi.json -o clients/python/nfex_client/schema.py

Every component schema a 2xx response (or the ``Problem`` of an error) refers to becomes a ``TypedDict``:
required members as plain keys, optional ones ``NotRequired``. The service's pydantic models
(service/schemas/) are the single source; ``tests/clients/test_client_types.py`` regenerates this file
from a running service's document and fails when the committed one differs, so the two cannot drift.
Only the JSON Schema the service emits is handled (objects, arrays, maps, ``anyOf``, scalars, ``$ref``);
anything else is an error rather than a silent ``Any``.
"""
from __future__ import annotations

import json
import keyword
import sys
from collections.abc import Iterator
from typing import Any

REF = "#/components/schemas/"
SCALARS = {"string": "str", "integer": "int", "number": "float", "boolean": "bool", "null": "None"}
HEADER = '''"""Response types of the nFEX service: generated from its OpenAPI document by ``python -m nfex_client.generate``.

Do not edit: change the service's schemas (service/schemas/) and regenerate.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypedDict

if TYPE_CHECKING:
    from typing_extensions import NotRequired  # noqa: UP035 - the client runs on Python 3.10 too
'''


def _refs(node: Any) -> Iterator[str]:
    if isinstance(node, dict):
        ref = node.get("$ref")
        if isinstance(ref, str) and ref.startswith(REF):
            yield ref[len(REF):]
        for value in node.values():
            yield from _refs(value)
    elif isinstance(node, list):
        for value in node:
            yield from _refs(value)


def response_schemas(doc: dict[str, Any]) -> list[str]:
    """The component schemas reachable from the documented responses, sorted by name."""
    schemas = doc["components"]["schemas"]
    todo = [name for item in doc["paths"].values() for op in item.values() if isinstance(op, dict)
            for name in _refs(op.get("responses", {}))]
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo.extend(_refs(schemas[name]))
    return sorted(seen)


def annotation(schema: dict[str, Any], where: str) -> str:
    """The Python type of a JSON Schema (as the service writes them)."""
    if "$ref" in schema:
        return str(schema["$ref"]).removeprefix(REF)
    if "anyOf" in schema:
        return " | ".join(annotation(s, where) for s in schema["anyOf"])
    kind = schema.get("type")
    if kind in SCALARS:
        return SCALARS[kind]
    if kind == "array":
        return f"list[{annotation(schema.get('items', {}), where)}]"
    if kind == "object" and "properties" not in schema:
        extra = schema.get("additionalProperties", True)
        return f"dict[str, {annotation(extra, where) if isinstance(extra, dict) and extra else 'Any'}]"
    if kind is None and not set(schema) - {"title", "description", "default"}:
        return "Any"
    raise ValueError(f"{where}: no Python type for the JSON Schema {json.dumps(schema)[:200]}")


def typed_dict(name: str, schema: dict[str, Any]) -> str:
    """One TypedDict; a schema with a key that is no Python name (e.g. ``from``) uses the call syntax."""
    if schema.get("type") != "object" or "properties" not in schema:
        return f"{name} = {annotation(schema, name)}\n"
    required = set(schema.get("required", []))
    members = []
    for key, prop in schema["properties"].items():
        kind = annotation(prop, f"{name}.{key}")
        members.append((key, kind if key in required else f"NotRequired[{kind}]"))
    doc = (schema.get("description") or "").strip().splitlines()
    if any(not k.isidentifier() or keyword.iskeyword(k) for k, _ in members):
        fields = ", ".join(f"{k!r}: {t!r}" for k, t in members)
        lines = [f"{name} = TypedDict({name!r}, {{{fields}}})"]
        return "\n".join(([f"# {doc[0]}"] if doc else []) + lines) + "\n"
    lines = [f"class {name}(TypedDict):"]
    if doc:
        lines.append(f'    """{doc[0]}"""')
        lines.append("")
    lines += [f"    {k}: {t}" for k, t in members]
    return "\n".join(lines) + "\n"


def render(doc: dict[str, Any]) -> str:
    """The text of ``nfex_client/schema.py`` for ``doc``."""
    schemas = doc["components"]["schemas"]
    names = response_schemas(doc)
    body = "\n\n".join(typed_dict(n, schemas[n]) for n in names)
    exports = ", ".join(repr(n) for n in names)
    return f"{HEADER}\n\n{body}\n\n__all__ = [{exports}]\n"


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    output = None
    if len(args) == 3 and args[1] in ("-o", "--output"):
        args, output = args[:1], args[2]
    if len(args) != 1:
        sys.exit("usage: python -m nfex_client.generate URL-or-FILE-of-openapi.json [-o nfex_client/schema.py]")
    source = args[0]
    if source.startswith(("http://", "https://")):
        import httpx

        doc = httpx.get(source, timeout=30).raise_for_status().json()
    else:
        with open(source, encoding="utf-8") as f:
            doc = json.load(f)
    text = render(doc)  # written only once complete: the package being regenerated imports the old file
    if output is None:
        sys.stdout.write(text)
    else:
        with open(output, "w", encoding="utf-8") as f:
            f.write(text)


if __name__ == "__main__":
    main()
