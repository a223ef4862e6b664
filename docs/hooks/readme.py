"""MkDocs hook: the site's home page is README.md, its links made relative to docs/, so
the two cannot drift apart (docs/index.md holds only a pointer)."""

from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def on_page_markdown(markdown, page, config, files):
    if page.file.src_uri != "index.md":
        return markdown
    return README.read_text().replace("](docs/", "](")
