"""MkDocs hook: pages that are generated from the code, so that they cannot go stale.

Markers in the Markdown pages, replaced at build time:

``[[code: dotted.name | `text`]]``
    The line of ``dotted.name``'s source that contains ``text``: its file, line number and the
    line itself, linked to the object's API entry. The build fails if the object or the text
    is gone — a moved equation breaks the docs build instead of silently pointing elsewhere.
``[[lines: dotted.name]]``
    The object, its file and its first and last source lines.
``[[cli]]``
    The reference of every ``svrqp`` subcommand, from the Typer application itself.
``[[notebooks]]``
    A table of the notebooks in ``notebooks/``: file and title (the first heading of each).
``[[config: dotted.Class]]``
    A configuration dataclass as a table: each field, its default and its documented meaning.
``[[include: path | language]]``
    A repository file as a fenced code block (the build fails when it is missing).
``[[include-optional: glob]]``
    Every repository Markdown file matching the glob (e.g. recorded benchmark results) inlined,
    with its images published next to the page; a note when none has been recorded yet.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
import sys
import posixpath
import re
from pathlib import Path

import griffe
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

sys.path.insert(0, str(Path(__file__).parent))
from rst import rst_to_markdown  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
_MARKERS = {
    "code": re.compile(r"\[\[code:\s*([\w.]+)\s*\|\s*`([^`]+)`\s*\]\]"),
    "lines": re.compile(r"\[\[lines:\s*([\w.]+)\s*\]\]"),
    "cli": re.compile(r"\[\[cli\]\]"),
    "notebooks": re.compile(r"\[\[notebooks\]\]"),
    "config": re.compile(r"\[\[config:\s*([\w.]+)\s*\]\]"),
    "include": re.compile(r"\[\[include:\s*([^\s|\]]+)\s*\|\s*(\w*)\s*\]\]"),
    "include-optional": re.compile(r"\[\[include-optional:\s*([^\s\]]+)\s*\]\]"),
}
_ANY_MARKER = re.compile(r"\[\[\s*(?:code|lines|cli|config|notebooks|include)[^\]]*")
_IMAGE = re.compile(r"!\[([^\]]*)\]\((?!https?://)([^)]+)\)")


def _resolve(dotted: str) -> object:
    parts = dotted.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ImportError:
            continue
        try:
            for name in parts[split:]:
                obj = getattr(obj, name)
        except AttributeError as err:
            raise PluginError(f"docs: {dotted!r} does not exist ({err})") from None
        return inspect.unwrap(obj)
    raise PluginError(f"docs: cannot import any module of {dotted!r}")


def _source(dotted: str) -> tuple[str, list[str], int]:
    obj = _resolve(dotted)
    try:
        lines, first = inspect.getsourcelines(obj)
        path = Path(inspect.getsourcefile(obj)).resolve().relative_to(ROOT)
    except (TypeError, OSError, ValueError) as err:
        raise PluginError(f"docs: no source for {dotted!r}: {err}") from None
    return path.as_posix(), lines, max(first, 1)  # a module reports line 0


def _name(dotted: str) -> str:
    """The object's short name, linked to its API entry when it is public."""
    short = dotted.rsplit(".", 1)[-1]
    public = not any(part.startswith("_") for part in dotted.split("."))
    return f"[`{short}`][{dotted}]" if public else f"`{short}`"


def _code(dotted: str, needle: str) -> str:
    path, lines, first = _source(dotted)
    hits = [i for i, line in enumerate(lines) if needle in line]
    if not hits:
        raise PluginError(f"docs: no line of {dotted} contains {needle!r} — update the page")
    line = lines[hits[0]].strip()
    return f"{_name(dotted)} · `{path}:{first + hits[0]}` · `{line}`"


def _lines(argument: str) -> str:
    path, lines, first = _source(argument)
    return f"{_name(argument)} · `{path}`, lines {first}–{first + len(lines) - 1}"


def _cli() -> str:
    import typer
    from typer.cli import get_docs_for_click
    from typer.main import get_command

    from svrqp.cli import app

    command = get_command(app)
    text = get_docs_for_click(obj=command, ctx=typer.Context(command), name="svrqp", title="svrqp")
    return re.sub(r"^(#+) ", r"#\1 ", text, flags=re.MULTILINE)  # below the page's own title


def _short_default(field: dataclasses.Field) -> str:
    if field.default is not dataclasses.MISSING:
        value = field.default
    elif field.default_factory is not dataclasses.MISSING:
        value = field.default_factory()
    else:
        return "required"
    if dataclasses.is_dataclass(value):
        return f"`{type(value).__name__}()`"
    if isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
        return f"{len(value)} × `{type(value[0]).__name__}`"
    return f"`{value!r}`"


def _config(dotted: str) -> str:
    cls = _resolve(dotted)
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise PluginError(f"docs: [[config: {dotted}]] is not a dataclass")
    described = {}
    for section in griffe.Docstring(inspect.getdoc(cls) or "").parse("numpy", warn_missing_types=False):
        if section.kind is griffe.DocstringSectionKind.parameters:
            described.update({p.name: " ".join(p.description.split()) for p in section.value})
    missing = [f.name for f in dataclasses.fields(cls) if f.init and f.name not in described]
    if missing:
        raise PluginError(f"docs: {dotted} does not document field(s) {missing}")
    rows = [f"| `{f.name}` | {_short_default(f)} | {rst_to_markdown(described[f.name])} |"
            for f in dataclasses.fields(cls) if f.init]
    return "\n".join(["| parameter | default | meaning |", "|---|---|---|", *rows])


def _notebooks() -> str:
    rows = []
    for path in sorted((ROOT / "notebooks").glob("*.ipynb")):
        cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
        heading = next((line for cell in cells if cell["cell_type"] == "markdown"
                        for line in "".join(cell["source"]).splitlines() if line.startswith("# ")), None)
        if heading is None:
            raise PluginError(f"docs: {path.name} has no '# ' title in a markdown cell")
        rows.append(f"| [`{path.name}`](notebooks/{path.name}) | {heading[2:].strip()} |")
    if not rows:
        raise PluginError("docs: no notebook found in notebooks/")
    return "\n".join(["| notebook | what it does |", "|---|---|", *rows])


def _include(relative: str, language: str) -> str:
    path = ROOT / relative
    if not path.is_file():
        raise PluginError(f"docs: [[include: {relative}]]: file not found")
    return f"```{language}\n{path.read_text(encoding='utf-8').rstrip()}\n```"


def _include_optional(pattern: str, published: dict[str, Path], page_dir: str = "") -> str:
    """Every repository Markdown file matching ``pattern`` (a glob), or a note when there is none."""
    paths = sorted(path for path in ROOT.glob(pattern) if path.is_file())
    if not paths:
        return (f'!!! note "Not recorded yet"\n    No file matches `{pattern}` in this checkout; it is '
                "written by the command that records these results (see the CLI reference).")
    return "\n\n".join(_inline_markdown(path, published, page_dir) for path in paths)


def _inline_markdown(path: Path, published: dict[str, Path], page_dir: str) -> str:
    def publish(match: re.Match) -> str:
        image = (path.parent / match[2]).resolve()
        uri = f"assets/generated/{image.relative_to(ROOT).as_posix().replace('/', '_')}"
        published[uri] = image
        return f"![{match[1]}]({posixpath.relpath(uri, page_dir or '.')})"

    text = _IMAGE.sub(publish, path.read_text(encoding="utf-8"))
    source = f"*From `{path.relative_to(ROOT).as_posix()}`.*\n\n"
    return source + re.sub(r"^(#+) ", r"#\1 ", text, flags=re.MULTILINE)


_published: dict[str, Path] = {}


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Replace the markers of the module docstring; a malformed marker fails the build."""
    page_dir = posixpath.dirname(page.file.src_uri)
    markdown = _MARKERS["code"].sub(lambda m: _code(m[1], m[2]), markdown)
    markdown = _MARKERS["lines"].sub(lambda m: _lines(m[1]), markdown)
    markdown = _MARKERS["cli"].sub(lambda m: _cli(), markdown)
    markdown = _MARKERS["config"].sub(lambda m: _config(m[1]), markdown)
    markdown = _MARKERS["notebooks"].sub(lambda m: _notebooks(), markdown)
    markdown = _MARKERS["include"].sub(lambda m: _include(m[1], m[2]), markdown)
    markdown = _MARKERS["include-optional"].sub(lambda m: _include_optional(m[1], _published, page_dir), markdown)
    leftover = _ANY_MARKER.search(markdown)
    if leftover:
        raise PluginError(f"docs: malformed marker in {page.file.src_uri}: {leftover[0]!r}")
    return markdown


def on_files(files, config):
    """Publish the images that optional includes refer to (collected on a first scan)."""
    for page in files.documentation_pages():
        for argument in _MARKERS["include-optional"].findall(page.content_string):
            _include_optional(argument, _published)
    for uri, image in _published.items():
        if image.is_file() and files.get_file_from_path(uri) is None:
            files.append(File.generated(config, uri, abs_src_path=str(image)))
    return files


# mkdocs-jupyter writes a MathJax 2 set-up into every notebook page: a script tag with an empty
# source and a "text/x-mathjax-config" block. The site has one MathJax 3 set-up (mkdocs.yml's
# extra_javascript, bundled); these two would only load nothing or a second, CDN copy.
_NOTEBOOK_MATHJAX = (re.compile(r'<script src="">\s*</script>\s*'),
                     re.compile(r'<script type="text/x-mathjax-config">.*?</script>\s*', re.DOTALL))


def on_post_page(output: str, page, config) -> str:
    """Remove the notebook converter's own MathJax 2 scripts; the site's MathJax 3 renders the maths."""
    if not page.file.src_uri.endswith(".ipynb"):
        return output
    for pattern in _NOTEBOOK_MATHJAX:
        output = pattern.sub("", output)
    return output
