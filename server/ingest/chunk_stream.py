"""Framed SceneChunk output of the USD reader (proto/pbgi/v1/scene.proto).

Each chunk goes to the binary stream as a 4-byte little-endian length
followed by the serialized SceneChunk; the daemon (server/ingest/
usd_ingest.cpp) decodes the same framing. Diagnostics are de-duplicated here
so that one unsupported prim yields exactly one message.
"""
import struct
import sys
import time

from pbgi.v1 import scene_pb2

WARNING = scene_pb2.Diagnostic.WARNING
ERROR = scene_pb2.Diagnostic.ERROR
INFO = scene_pb2.Diagnostic.INFO

_LENGTH = struct.Struct("<I")
# Progress is throttled: the daemon forwards it to clients, and a chunk per
# prim would dominate small scenes.
_PROGRESS_INTERVAL_S = 0.1


class ChunkStream:
    """Writes SceneChunk frames to a binary file object (not thread-safe)."""

    def __init__(self, out, roots=None):
        self._out = out
        # AssetRoots (asset_roots.py): every file path a chunk carries is
        # checked here, the one place all chunks pass, before it is sent.
        self._roots = roots
        self._reported = set()
        self._last_progress = 0.0
        self.chunk_count = 0  # every frame written, as SceneEnd reports it
        self.triangle_count = 0
        # Set once the stage is open: diagnostics then name the file that
        # defines their prim (bad input must be traceable to its layer).
        self.stage = None
        # Nonzero while a prototype's geometry is written (prototypes.py):
        # mesh and cage chunks are then tagged with it.
        self.prototype_id = 0

    def check_file(self, path, what):
        """Confines a file the scene names but no chunk will carry (one that
        does not exist, say) to the scene roots: raises OutsideRoots naming
        `what`, never the path."""
        if self._roots is not None:
            self._roots.check(path, what)

    def write(self, chunk):
        if self.prototype_id and chunk.WhichOneof("body") in ("mesh", "subdiv_cage"):
            getattr(chunk, chunk.WhichOneof("body")).prototype_id = self.prototype_id
        if self._roots is not None:
            self._roots.check_chunk(chunk)
        data = chunk.SerializeToString()
        self._out.write(_LENGTH.pack(len(data)))
        self._out.write(data)
        self.chunk_count += 1

    def diagnostic(self, severity, prim_path, message, kind=""):
        """Reports once per (kind, prim path); kind defaults to the message."""
        key = (kind or message, prim_path)
        if key in self._reported:
            return
        self._reported.add(key)
        label = scene_pb2.Diagnostic.Severity.Name(severity)
        layer = self._defining_layer(prim_path)
        print(f"usd_reader: {label}: {prim_path}: {message}" + (f" (in {layer})" if layer else ""),
              file=sys.stderr)
        chunk = scene_pb2.SceneChunk()
        chunk.diagnostic.severity = severity
        chunk.diagnostic.prim_path = prim_path
        chunk.diagnostic.message = message
        chunk.diagnostic.layer = layer
        self.write(chunk)

    def _defining_layer(self, prim_path):
        """Path of the layer holding the prim's strongest `def` spec (else
        its strongest spec), or ""."""
        if self.stage is None or not prim_path.startswith("/"):
            return ""
        try:
            from pxr import Sdf
            prim = self.stage.GetPrimAtPath(prim_path)
            if not prim:
                return ""
            stack = prim.GetPrimStack()
            if not stack:
                return ""
            files = [s for s in stack if not s.layer.anonymous] or stack
            spec = next((s for s in files if s.specifier == Sdf.SpecifierDef), files[0])
            return spec.layer.realPath or spec.layer.identifier
        except Exception:  # naming the file must never fail the read
            return ""

    def progress(self, stage, fraction, force=False):
        now = time.monotonic()
        if not force and now - self._last_progress < _PROGRESS_INTERVAL_S:
            return
        self._last_progress = now
        chunk = scene_pb2.SceneChunk()
        chunk.progress.stage = stage
        chunk.progress.fraction = min(max(fraction, 0.0), 1.0)
        self.write(chunk)

    def end(self):
        chunk = scene_pb2.SceneChunk()
        # SceneEnd counts every frame before it, itself excluded.
        chunk.end.triangle_count = self.triangle_count
        chunk.end.chunk_count = self.chunk_count
        self.write(chunk)
        self._out.flush()
