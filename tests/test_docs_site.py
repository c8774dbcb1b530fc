"""The documentation site in a real browser: the site is built from a copy of docs/ and
demos/ with the gallery's demos not run (``scripts/build-docs --no-run``: the gallery pages
have their text, code and stored figures, no quick-mode output; the demos themselves run in
tests/test_demos.py), then headless Chromium opens the index, a gallery page and the API
page: each renders (a screenshot that is not blank; the DOM as the browser built it holds the
page's title and its <img> elements), its images load (every <img src> is a non-empty file of
the site) and its internal links resolve (every relative href of every built page names a
file of the site). The screenshots are kept in scratch/docs-site/ (PNG). Serial only: the
2-rank pass skips it (nothing here is parallel)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from conftest import child_env
from mpi4py import MPI

REPO = Path(__file__).resolve().parents[1]
SHOTS = REPO / "scratch" / "docs-site"
#: page: (file, a title it shows, whether it shows images)
PAGES = {"index": ("index.html", "shells", True),
         "gallery": ("gallery/fig3_sphere.html", "Fig. 3: the closed sphere", True),
         "api": ("api.html", "Python API", False)}


class _Refs(HTMLParser):
    """The page's <img src> and <a href> (and <link href>) values."""

    def __init__(self) -> None:
        super().__init__()
        self.imgs: list[str] = []
        self.hrefs: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img" and a.get("src"):
            self.imgs.append(a["src"])
        if tag in ("a", "link") and a.get("href"):
            self.hrefs.append(a["href"])


def _refs(html: str) -> _Refs:
    p = _Refs()
    p.feed(html)
    return p


def _local(page: Path, ref: str) -> Path | None:
    """The file a relative reference of ``page`` names, or None for another site's."""
    u = urlsplit(ref)
    if u.scheme or u.netloc or ref.startswith(("#", "mailto:", "javascript:")):
        return None
    return (page.parent / unquote(u.path)).resolve() if u.path else None


def _build(tmp: Path) -> Path:
    """The site from a copy of what it is built from (the build writes the gallery's pages
    into its source folder), demos not run; its html folder."""
    src = tmp / "repo"
    shutil.copytree(REPO / "docs", src / "docs", ignore=shutil.ignore_patterns("_build",
                                                                               "gallery"))
    shutil.copytree(REPO / "demos", src / "demos")
    shutil.copytree(REPO / "benchmarks" / "results", src / "benchmarks" / "results",
                    ignore=lambda d, names: [n for n in names if not (
                        n.endswith(".png") or (Path(d) / n).is_dir())])
    out = tmp / "html"
    r = subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going",
                        "-q", str(src / "docs"), str(out)], capture_output=True, text=True,
                       env=child_env(SHELLS_DOCS_RUN_DEMOS="0"), timeout=240)
    assert r.returncode == 0, r.stdout + r.stderr
    return out


def _chromium(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--disable-dev-shm-usage", *args],
                          capture_output=True, text=True, timeout=90, env=child_env())


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    if MPI.COMM_WORLD.size > 1:
        pytest.skip("the site is checked in the serial pass")
    if shutil.which("chromium") is None:
        return None
    return _build(tmp_path_factory.mktemp("docs"))


@pytest.mark.parametrize("which", sorted(PAGES))
def test_a_page_renders_in_chromium_with_its_images_and_links(site, which):
    if MPI.COMM_WORLD.rank != 0:
        return
    if site is None:
        pytest.skip("chromium is not installed (deps/debian-packages.txt lists it)")
    rel, title, images = PAGES[which]
    page = site / rel
    assert page.is_file()
    SHOTS.mkdir(parents=True, exist_ok=True)
    shot = SHOTS / f"{which}.png"
    shot.unlink(missing_ok=True)
    url = page.as_uri()
    r = _chromium("--window-size=1280,1600", f"--screenshot={shot}", url)
    assert shot.is_file() and shot.stat().st_size > 20_000, r.stderr[-2000:]
    from matplotlib.image import imread

    pixels = imread(shot)
    assert pixels.std() > 0.05  # not a blank page

    dom = _chromium("--dump-dom", "--virtual-time-budget=3000", url).stdout
    assert title in dom and "</html>" in dom.lower()
    refs = _refs(dom)
    assert bool(refs.imgs) == images, f"{rel}: images {refs.imgs}"
    if which == "api":  # the reference generated from the docstrings
        assert "shells.critical" in dom and "shells.Shell" in dom
    for src in refs.imgs:
        f = _local(page, src)
        if f is not None:
            assert f.is_file() and f.stat().st_size > 0, f"{rel}: image {src} does not load"


def test_every_internal_link_of_the_site_resolves(site):
    if MPI.COMM_WORLD.rank != 0:
        return
    if site is None:
        pytest.skip("chromium is not installed")
    broken = []
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 15
    for page in pages:
        refs = _refs(page.read_text(encoding="utf-8"))
        for ref in refs.hrefs + refs.imgs:
            f = _local(page, ref)
            if f is not None and not f.exists():
                broken.append(f"{page.relative_to(site)} -> {ref}")
    assert not broken, "\n".join(broken[:20])


def test_the_site_needs_no_network_for_its_equations(site):
    """MathJax is part of the site (Debian's libjs-mathjax, copied by docs/conf.py)."""
    if MPI.COMM_WORLD.rank != 0 or site is None:
        return
    assert (site / "_static" / "mathjax" / "MathJax.js").is_file()
    assert "_static/mathjax/MathJax.js" in (site / "user-guide.html").read_text()
    assert os.path.getsize(site / "_static" / "mathjax" / "MathJax.js") > 0
