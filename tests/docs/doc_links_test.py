#!/usr/bin/env python3
"""Fails when a document of the repository points at something that is not there.

Checks README.md, docs/**/*.md and every other tracked *.md file:
  * Markdown links and images, [text](target) / ![alt](target), whose
    target is not a URL or an anchor: the file must exist, resolved from the
    document's folder, and stay inside the repository;
  * backticked names of Markdown files (`docs/gather.md`,
    `measurements/2026-11-25-light-leak.md`): they must exist, resolved from
    the document's folder, from the repository root or from docs/;
  * design documents (docs/*.md, README.md) link nothing outside the
    repository (no http(s) links, no absolute paths).
Usage: doc_links_test.py [REPO_ROOT]   (default: two folders up from here)
       doc_links_test.py --self-test     (the checker finds planted faults)
Exit status 0 when every reference resolves, 1 otherwise (each listed).
"""
import pathlib
import re
import sys

LINK = re.compile(r'!?\[[^\]]*\]\(([^)\s]+)(?:\s+"[^"]*")?\)')
TICKED_MD = re.compile(r'`([A-Za-z0-9_./-]+\.md)`')
FENCE = re.compile(r'^\s*(```|~~~)')


def documents(root):
    skip = {'.git', 'build', '.venv', 'node_modules'}
    for path in sorted(root.rglob('*.md')):
        parts = path.relative_to(root).parts
        if any(p in skip or p.startswith('build') or p.startswith('.') for p in parts[:-1]):
            continue
        yield path


def prose_lines(text):
    """Lines outside fenced code blocks, with their 1-based numbers."""
    fenced = False
    for number, line in enumerate(text.split('\n'), 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield number, line


def inside(root, path):
    try:
        path.resolve().relative_to(root.resolve())
        return True
    except ValueError:
        return False


def check(root):
    problems = []
    for doc in documents(root):
        rel = doc.relative_to(root)
        design = rel.parts[0] == 'README.md' or (rel.parts[0] == 'docs' and len(rel.parts) == 2)
        for number, line in prose_lines(doc.read_text(encoding='utf-8')):
            where = f'{rel}:{number}'
            for target in LINK.findall(line):
                if re.match(r'^[a-z]+:', target):
                    if design:
                        problems.append(f'{where}: link outside the repository: {target}')
                    continue
                if target.startswith('#'):
                    continue
                path_part = target.split('#', 1)[0]
                if path_part.startswith('/'):
                    problems.append(f'{where}: absolute path: {target}')
                    continue
                resolved = doc.parent / path_part
                if not inside(root, resolved):
                    problems.append(f'{where}: link leaves the repository: {target}')
                elif not resolved.exists():
                    problems.append(f'{where}: broken link: {target}')
            for name in TICKED_MD.findall(line):
                if 'YYYY' in name:  # a naming pattern, not a file
                    continue
                candidates = [doc.parent / name, root / name, root / 'docs' / name]
                if not any(inside(root, c) and c.exists() for c in candidates):
                    problems.append(f'{where}: no such document: {name}')
    return problems


def self_test():
    """Plants one fault of each kind in a temporary tree; all must be found."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        (root / 'docs' / 'measurements').mkdir(parents=True)
        (root / 'docs' / 'img').mkdir()
        (root / 'docs' / 'img' / 'a.png').write_bytes(b'')
        (root / 'docs' / 'measurements' / '2026-01-01-x.md').write_text('# x\n')
        (root / 'README.md').write_text(
            'ok [a](docs/gather.md) ![i](docs/img/a.png) `measurements/2026-01-01-x.md`\n'
            'bad [b](docs/missing.md) `docs/nowhere.md` [c](../outside.md)\n'
            '```\n[not a link](inside/a/fence.md)\n```\n')
        (root / 'docs' / 'gather.md').write_text(
            'see [web](https://example.com) and [img](img/a.png#x) and [self](#top)\n')
        found = check(root)
    expected = ['README.md:2: broken link: docs/missing.md',
                'README.md:2: no such document: docs/nowhere.md',
                'README.md:2: link leaves the repository: ../outside.md',
                'docs/gather.md:1: link outside the repository: https://example.com']
    if sorted(found) != sorted(expected):
        print('self-test: expected', expected, 'found', found)
        return 1
    print('self-test: the 4 planted faults were found, nothing else')
    return 0


def main():
    if sys.argv[1:] == ['--self-test']:
        return self_test()
    root = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2]
    problems = check(root)
    for p in problems:
        print(p)
    count = sum(1 for _ in documents(root))
    print(f'{count} documents, {len(problems)} problems')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
