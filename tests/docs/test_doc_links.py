#!/usr/bin/env python3
"""Every relative link in the repository's Markdown (README.md, docs/, examples/, configs/) names a
file that exists, and every #anchor a heading of that file (GitHub's slugs): a renamed document or
section breaks this test, not the next reader's click.

    tests/docs/test_doc_links.py REPO_ROOT
"""
import os
import re
import sys
import unittest

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^(```|~~~)")


def slug(heading):
    """GitHub's anchor of a heading: lower case, a link's text for the link, every character but
    letters, digits, '_', '-' and spaces dropped, spaces to '-'."""
    s = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip().lower())
    s = re.sub(r"[^\w\- ]", "", s, flags=re.UNICODE)
    return s.replace(" ", "-")


def anchors(path):
    found, counts, fenced = set(), {}, False
    with open(path, encoding="utf-8") as f:
        lines = f.readlines()
    for line in lines:
        if FENCE.match(line):
            fenced = not fenced
        if fenced or not line.startswith("#"):
            continue
        m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        base = slug(m.group(1))
        n = counts.get(base, 0)
        counts[base] = n + 1
        found.add(base if n == 0 else f"{base}-{n}")
    return found


def markdown_files(root):
    yield os.path.join(root, "README.md")
    for top in ("docs", "examples", "configs", "scripts", "tests", "experiments"):
        for d, dirs, files in os.walk(os.path.join(root, top)):
            dirs[:] = [x for x in dirs if x not in ("node_modules", "data")]
            for f in files:
                if f.endswith(".md"):
                    yield os.path.join(d, f)


def broken_links(root):
    bad = []
    for md in markdown_files(root):
        fenced = False
        with open(md, encoding="utf-8") as f:
            lines = f.readlines()
        for no, line in enumerate(lines, 1):
            if FENCE.match(line):
                fenced = not fenced
            if fenced:
                continue
            for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
                if re.match(r"^[a-z]+:", target):  # https:, mailto:
                    continue
                path, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(md), path)) if path else md
                where = f"{os.path.relpath(md, root)}:{no}: {target}"
                if not os.path.exists(dest):
                    bad.append(f"{where}: no such file")
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    bad.append(f"{where}: no heading with that anchor in {os.path.relpath(dest, root)}")
    return bad


class DocLinks(unittest.TestCase):
    def test_slugs_follow_github(self):
        self.assertEqual(slug("The envelope (`race.mach_max`, `race.mach_governor`)"),
                         "the-envelope-racemach_max-racemach_governor")
        self.assertEqual(slug("Rewards (per LL step)"), "rewards-per-ll-step")
        self.assertEqual(slug("Does the high level learn?"), "does-the-high-level-learn")

    def test_a_missing_file_and_anchor_are_found(self):
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            os.makedirs(os.path.join(d, "docs"))
            with open(os.path.join(d, "README.md"), "w") as f:
                f.write("[a](docs/a.md#there) [b](docs/b.md) [c](docs/a.md#nowhere) [w](https://x.org/y)\n")
            with open(os.path.join(d, "docs", "a.md"), "w") as f:
                f.write("# There\n")
            bad = broken_links(d)
            self.assertEqual(len(bad), 2, bad)
            self.assertIn("docs/b.md: no such file", bad[0])
            self.assertIn("docs/a.md#nowhere: no heading", bad[1])

    def test_the_repository_has_no_broken_link(self):
        bad = broken_links(ROOT)
        self.assertEqual(bad, [], "\n" + "\n".join(bad))


if __name__ == "__main__":
    ROOT = os.path.abspath(sys.argv.pop(1)) if len(sys.argv) > 1 else os.getcwd()
    unittest.main()
