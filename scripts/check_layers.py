#!/usr/bin/env python3
"""Fails when an #include crosses a layer upward, or a name is declared
outside its folder's namespace.

The layers of pbgi, lowest first, are written once, in LAYERS below
(docs/architecture.md explains them). A source file may include
  * a file of its own folder;
  * a file of a folder listed before its own in the same layer (the
    server's stages in data-flow order: a stage includes only earlier ones);
  * a file of a layer its layer builds on ("on").
One more rule: the client library and CLI (layer "client") talk to the
daemon over the wire only. Of the storage and server layers they include
just the options headers: the headers the stages expose through their
header-only pbgi_*_options targets (`pbgi_headers(pbgi_<x>_options FILES
...)` in the folders' CMakeLists.txt, read from there), which derive the
CLI's flags. Such a header itself includes only common/ and other options
headers, so that a client compiles no stage.

The build enforces that a target includes only what it links
(cmake/PbgiHeaders.cmake); this check enforces the direction.

Checked: C++ files (.h, .cpp, .cc) under common/, proto/, storage/,
server/, client/; quoted includes only (<...> is a third party's or the
standard library's). A folder under those that no layer lists is an error
too: a new folder must take its place in LAYERS.

Namespaces (the rule docs/architecture.md states): a file declares its
names in `pbgi` or one level below it, in a namespace named after its
folder (pbgi::gather in server/gather/) or after the library the folder
builds (client/lib builds pbgi_client: pbgi::client); storage's folders
may also share pbgi::storage. Deeper namespaces are the file's own
helpers (detail, anonymous); namespaces outside pbgi (a third party's,
specialised or forward-declared) are not checked.

Usage: check_layers.py [REPO_ROOT]   (default: one folder up from here)
       check_layers.py --self-test     (the checker finds planted faults)
Exit status 0 when no include crosses a layer upward, 1 otherwise (each
listed as file:line: what).
"""
import pathlib
import re
import sys

# (layer, the layers it builds on, its folders lowest first)
LAYERS = [
    ('common', [], ['common', 'common/options']),
    ('proto', ['common'], ['proto', 'pbgi/v1']),  # pbgi/v1: the generated headers
    ('storage', ['common'],
     ['storage/format', 'storage/sh', 'storage/tree', 'storage/codecs', 'storage/cache', 'storage/pages']),
    ('server', ['common', 'proto', 'storage'],
     ['server/scene', 'server/volumes', 'server/ingest', 'server/surfels', 'server/gather', 'server/render',
      'server/reference', 'server/engine', 'server/service', 'server/daemon']),
    ('client', ['common', 'proto', 'options'],
     ['client/lib', 'client/image', 'client/metrics', 'client/stress', 'client/cli']),
    # In-process tools (pbgi-tools): the pipeline and the client together.
    ('tools', ['common', 'proto', 'storage', 'server', 'client'], ['client/bench', 'client/tools']),
]
ROOTS = ['common', 'proto', 'storage', 'server', 'client']
EXTENSIONS = {'.h', '.cpp', '.cc'}
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')
LIBRARY = re.compile(r'add_library\(pbgi_(\w+)\s+STATIC')
NAMESPACE_OPEN = re.compile(r'^\s*namespace(?:\s+([\w:]+))?\s*\{')
STRINGS = re.compile(r'"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])*\'')
OPTIONS_TARGET = re.compile(r'pbgi_headers\(\s*pbgi_\w+_options\s+FILES\s+([^)]*)\)')


def folder_rank():
    """folder -> (layer, position in the layer)."""
    return {folder: (layer, i) for layer, _, folders in LAYERS for i, folder in enumerate(folders)}


def options_headers(root):
    """The headers the pbgi_*_options targets expose, as repository paths."""
    found = set()
    for cmake in sorted(root.rglob('CMakeLists.txt')):
        rel = cmake.parent.relative_to(root)
        if not rel.parts or rel.parts[0] not in ROOTS:
            continue
        for match in OPTIONS_TARGET.finditer(cmake.read_text(encoding='utf-8')):
            for name in match.group(1).split():
                found.add((rel / name).as_posix())
    return found


def namespaces_allowed(root, folder):
    """The namespaces one level below pbgi that files of `folder` may open."""
    allowed = {pathlib.PurePosixPath(folder).name}
    if folder.startswith('storage/'):
        allowed.add('storage')
    cmake = root / folder / 'CMakeLists.txt'
    if cmake.exists():
        allowed.update(LIBRARY.findall(cmake.read_text(encoding='utf-8')))
    return allowed


def namespace_problems(rel, text, allowed):
    """Lines of `text` that open pbgi::x, x not in `allowed`."""
    problems = []
    stack = []  # (namespace path, brace depth it opened at)
    depth = 0
    for number, line in enumerate(text.split('\n'), 1):
        code = STRINGS.sub('""', line).split('//')[0]
        match = NAMESPACE_OPEN.match(code)
        if match:
            outer = stack[-1][0] if stack else ''
            name = match.group(1) or '<anonymous>'
            path = f'{outer}::{name}' if outer else name
            parts = path.split('::')
            if parts[0] == 'pbgi' and len(parts) > 1 and outer in ('', 'pbgi') and parts[1] not in allowed \
                    and parts[1] != '<anonymous>':
                problems.append(f'{rel}:{number}: namespace pbgi::{parts[1]}, not one of its folder\'s: '
                                + ', '.join(f'pbgi::{a}' for a in sorted(allowed)))
            stack.append((path, depth))
        for ch in code:
            if ch == '{':
                depth += 1
            elif ch == '}':
                depth -= 1
                while stack and depth <= stack[-1][1]:
                    stack.pop()
    return problems


def sources(root):
    for top in ROOTS:
        for path in sorted((root / top).rglob('*')):
            if path.suffix in EXTENSIONS and path.is_file():
                yield path


def allowed(src_folder, inc_folder, inc_path, ranks, builds_on, contract):
    """None if src_folder may include inc_path, else why not."""
    if inc_folder == src_folder:
        return None
    if inc_folder not in ranks:
        return f'includes {inc_path}, whose folder no layer lists'
    src_layer, src_pos = ranks[src_folder]
    inc_layer, inc_pos = ranks[inc_folder]
    if inc_layer == src_layer:
        return None if inc_pos < src_pos else f'includes {inc_path}: {inc_folder} is above {src_folder} in layer {src_layer}'
    if inc_layer in builds_on[src_layer]:
        return None
    if 'options' in builds_on[src_layer] and inc_path in contract:
        return None
    return f'includes {inc_path}: layer {src_layer} does not build on layer {inc_layer}'


def check(root):
    ranks = folder_rank()
    builds_on = {layer: set(on) for layer, on, _ in LAYERS}
    contract = options_headers(root)
    problems = []
    for path in sources(root):
        rel = path.relative_to(root)
        src_folder = rel.parent.as_posix()
        if src_folder not in ranks:
            problems.append(f'{rel}: folder {src_folder} is in no layer (scripts/check_layers.py, LAYERS)')
            continue
        text = path.read_text(encoding='utf-8', errors='replace')
        problems += namespace_problems(rel, text, namespaces_allowed(root, src_folder))
        for number, line in enumerate(text.split('\n'), 1):
            match = INCLUDE.match(line)
            if not match:
                continue
            inc = match.group(1)
            inc_folder = str(pathlib.PurePosixPath(inc).parent)
            if inc_folder == '.':  # a bare name: beside the including file
                inc_folder = src_folder
                inc = f'{src_folder}/{inc}'
            if rel.as_posix() in contract and inc_folder != 'common/options' and inc_folder != 'common' \
                    and inc not in contract:
                problems.append(f'{rel}:{number}: an options header includes {inc}, which is not one')
                continue
            why = allowed(src_folder, inc_folder, inc, ranks, builds_on, contract)
            if why:
                problems.append(f'{rel}:{number}: {why}')
    return problems


def self_test():
    """Plants one fault of each kind in a temporary tree; all must be found."""
    import tempfile
    files = {
        'common/errors.h': '',
        'common/options/option_table.h': '#include "common/errors.h"\n',
        'storage/format/checksum.h': '#include "common/errors.h"\n#include "server/gather/gather.h"\n',
        'storage/format/frame.h': '#include "storage/pages/page_set.h"\n#include <vector>\n',
        'storage/tree/node.h': '#include "storage/format/checksum.h"\n#include "local.h"\n',
        'storage/tree/local.h': '',
        'storage/pages/page_set.h': '#include "storage/tree/node.h"\n',
        'server/gather/gather.h': '#include "server/gather/gather_options.h"\n#include "server/scene/scene.h"\n',
        'server/gather/gather_options.h': '#include "common/options/option_table.h"\n'
                                          '#include "server/gather/microbuffer.h"\n',
        'server/gather/microbuffer.h': '',
        'server/gather/CMakeLists.txt': 'pbgi_headers(pbgi_gather_options FILES gather_options.h)\n',
        'server/scene/scene.h': '#include "storage/tree/node.h"\n',
        'server/engine/scene_session.h': '#include "server/gather/gather.h"\n#include "pbgi/v1/pbgi.pb.h"\n',
        'server/newstage/thing.h': '',
        'client/lib/client.h': '#include "pbgi/v1/pbgi.pb.h"\n#include "common/errors.h"\n',
        'client/cli/flags.cpp': '#include "server/gather/gather_options.h"\n#include "client/lib/client.h"\n'
                                '#include "server/engine/scene_session.h"\n',
        'client/tools/cmd_bench.cpp': '#include "server/engine/scene_session.h"\n#include "client/cli/flags.h"\n'
                                      'namespace pbgi::tools {\nnamespace {\nusing cli::X;\n}  // namespace\n}\n',
        'client/lib/CMakeLists.txt': 'add_library(pbgi_client STATIC client.cpp)\n',
        'client/lib/client.cpp': 'namespace pbgi::client {\nvoid f() {\n  const char* s = "}";\n}\n}\n'
                                 'namespace pbgi {\nnamespace lib {\n}\n}  // namespace pbgi\n',
        'storage/tree/treelet.h': 'namespace pbgi::storage {\nclass Page;\n}\nnamespace pbgi::tree {\nnamespace detail {}\n}\n'
                                  'namespace pbgi::gather {\n}\n',
        'server/scene/scene.cpp': 'namespace grpc {\nclass Server;\n}\nnamespace pbgi {\nnamespace {\n}\n}\n',
    }
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        for name, text in files.items():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            (root / name).write_text(text)
        found = check(root)
    expected = [
        'storage/format/checksum.h:2: includes server/gather/gather.h: layer storage does not build on layer server',
        'storage/format/frame.h:1: includes storage/pages/page_set.h: storage/pages is above storage/format '
        'in layer storage',
        'server/gather/gather_options.h:2: an options header includes server/gather/microbuffer.h, which is not one',
        'server/newstage/thing.h: folder server/newstage is in no layer (scripts/check_layers.py, LAYERS)',
        'client/cli/flags.cpp:3: includes server/engine/scene_session.h: layer client does not build on layer server',
        'storage/tree/treelet.h:7: namespace pbgi::gather, not one of its folder\'s: pbgi::storage, pbgi::tree',
    ]
    if sorted(found) != sorted(expected):
        print('self-test: expected', *sorted(expected), 'found', *sorted(found), sep='\n  ')
        return 1
    print(f'self-test: the {len(expected)} planted faults were found, nothing else')
    return 0


def main():
    if sys.argv[1:] == ['--self-test']:
        return self_test()
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
    problems = check(root)
    for p in problems:
        print(p)
    if problems:
        print(f'{len(problems)} problem(s): an include crossing a layer upward, or a namespace outside its folder\'s')
        return 1
    print('layers: no include crosses a layer upward; namespaces follow their folders')
    return 0


if __name__ == '__main__':
    sys.exit(main())
