"""Draco meshes (.drc) that prims reference or payload.

Google's USD Draco plugin makes a .drc file a layer, so assets reference
meshes as `prepend references = @bunny.drc@`. usd-core ships no such file
format: USD reports the arc as a composition error ("Cannot determine file
format"). The reader turns exactly those arcs into MeshChunks carrying the
file's bytes (MeshChunk.draco) and the prim's local-to-world
(MeshChunk.draco_to_world); the daemon decodes them (server/ingest/
draco_mesh.h). The composition error is then not reported as a warning.
"""
import os
import re

from pbgi.v1 import scene_pb2

# The resolved asset in Pcp's message: @/abs/path/x.drc[:SDF_FORMAT_ARGS:...]@
_DRC_ASSET = re.compile(r"@([^@]+?\.drc)(?::SDF_FORMAT_ARGS[^@]*)?@", re.IGNORECASE)
# The daemon refuses frames above 256 MiB (scene_stream_decoder.h).
MAX_DRACO_BYTES = 192 << 20


def draco_arc_files(error_text):
    """The .drc files a composition error message is about (maybe none)."""
    return sorted(set(m.group(1) for m in _DRC_ASSET.finditer(error_text)))


def draco_chunks(prim_path, files, matrix, material_id, double_sided, matrix_floats):
    """(chunks, problems): a MeshChunk per readable file, and messages for
    the files that could not be read."""
    chunks, problems = [], []
    for path in files:
        try:
            size = os.path.getsize(path)
            if size > MAX_DRACO_BYTES:
                problems.append(f"Draco file '{path}' ({size} bytes) is too large for one chunk: skipped")
                continue
            with open(path, "rb") as f:
                data = f.read()
        except OSError as e:
            problems.append(f"cannot read Draco file '{path}': {e.strerror}")
            continue
        chunk = scene_pb2.SceneChunk()
        mesh = chunk.mesh
        mesh.prim_path = prim_path
        mesh.material_id = material_id
        mesh.double_sided = bool(double_sided)
        mesh.draco = data
        mesh.draco_to_world.extend(matrix_floats(matrix))
        chunks.append(chunk)
    return chunks, problems
