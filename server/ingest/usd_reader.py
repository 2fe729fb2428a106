#!/usr/bin/env python3
"""pbgi's USD reader process.

    usd_reader.py SCENE [--time CODE] [--max-triangles-per-chunk N]
                  [--variant /PRIM:SET=SELECTION ...] [--hash-only] [--flatten-instances]
                  [--scene-root DIR ...]

Opens SCENE with Pixar's USD (pxr) and writes the scene as framed SceneChunk
messages (proto/pbgi/v1/scene.proto; 4-byte little-endian length + bytes)
to stdout: SceneHeader, then materials, meshes, lights, cameras, diagnostics
and progress in traversal order, then SceneEnd. Nothing else goes to stdout
(the real stdout is claimed first and fd 1 is pointed at stderr, so stray
prints from Python or USD cannot corrupt the stream). Human-readable logs and
errors go to stderr.

The daemon (server/ingest/usd_ingest.cpp) runs this with PYTHONPATH holding
the generated protobuf package (<build>/python/pbgi/v1/scene_pb2.py).

With --scene-root, every file the scene uses must lie below one of the
roots (asset_roots.py), else the read stops before the file is read or its
path sent.

Exit codes: 0 success; 2 the scene cannot be opened (or bad arguments);
3 an unexpected failure while reading; 4 the daemon closed the pipe;
5 the scene uses a file outside the scene roots (the message names what
uses it, never the file); 6 a --variant selects nothing (no such prim,
variant set or variant).
"""
import argparse
import hashlib
import os
import re
import sys
import time as clock
import traceback

_STARTED = clock.monotonic()
# The reader's array work is a few large numpy passes; BLAS threads would only
# compete with the daemon's own threads for the cores.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
try:
    from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdShade, UsdSkel, UsdVol

    from asset_roots import AssetRoots, OutsideRoots, check_layer_graph, check_used_layers
    from camera_defs import camera_def
    from chunk_stream import ERROR, WARNING, ChunkStream
    from draco_refs import draco_arc_files, draco_chunks
    from gprim_triangles import read_implicit, read_mesh
    from implicit_shapes import is_implicit
    from light_defs import is_light, light_def, matrix_floats
    from materialx_looks import MaterialXLooks, mtlx_document_files, mtlx_error_files
    from pbgi.v1 import scene_pb2
    from point_instancers import read_point_instancer
    from preview_materials import MaterialTable
    from prototypes import PrototypeTable
    from subdiv_cages import total_cage_area
    from triangle_chunks import GeometryError, TriangleEmitter
    from volume_defs import volume_def
    _IMPORT_ERROR = None
except ImportError as e:  # reported by main() with a clear message
    _IMPORT_ERROR = e

# Bumped whenever the reader's output for the same input changes, so that
# caches keyed by the content hash are invalidated.
READER_VERSION = "pbgi-usd-reader/6"  # 6: subdiv_cage_area, XIncludes hashed, opacity
_HASH_BLOCK = 1 << 20
EXIT_OUTSIDE_ROOTS = 5
EXIT_BAD_SELECTION = 6


def _claim_stdout():
    """Returns a binary stream on the original stdout and routes fd 1 (and
    sys.stdout) to stderr for everything else."""
    sys.stdout.flush()
    fd = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return os.fdopen(fd, "wb", buffering=1 << 20)


def _fail(message, code):
    print(f"usd_reader: {message}", file=sys.stderr)
    return code


def _one_line(error):
    return re.sub(r"\s+", " ", str(error)).strip()[:600]


def _usd_error_text(error):
    """The messages of a Tf.ErrorException without USD's source locations."""
    text = _one_line(error)
    found = re.findall(r"in file \S+ : '(.*?)'(?=\s*Error in|\s*$)", text)
    return "; ".join(found) if found else text


def _parse_args(argv):
    parser = argparse.ArgumentParser(description="Writes a USD scene as SceneChunk frames.")
    parser.add_argument("scene")
    parser.add_argument("--time", type=float, default=None,
                        help="time code to read (default: the stage's startTimeCode if "
                             "authored, else 0)")
    parser.add_argument("--max-triangles-per-chunk", type=int, default=65536)
    parser.add_argument("--hash-only", action="store_true",
                        help="write only SceneHeader (with the content hash) and SceneEnd: "
                             "what a cache needs to know whether the scene changed")
    parser.add_argument("--variant", action="append", default=[], metavar="/PRIM:SET=SELECTION",
                        help="variant selection authored in the session layer before the stage "
                             "is composed (repeatable; wins over the file's selections)")
    parser.add_argument("--flatten-instances", action="store_true",
                        help="expand native instances and PointInstancers into world-space "
                             "triangles instead of prototypes + InstanceBatches")
    parser.add_argument("--scene-root", action="append", default=[], metavar="DIR",
                        help="confine every file the scene uses to these directories "
                             "(repeatable; none = unconfined)")
    args = parser.parse_args(argv)
    if args.max_triangles_per_chunk < 1:
        parser.error("--max-triangles-per-chunk must be >= 1")
    try:
        args.variants = [parse_variant(v) for v in args.variant]
    except ValueError as e:
        parser.error(str(e))
    return args


def parse_variant(text):
    """'/Prim/Path:set=selection' -> (prim path, set, selection). Prim paths
    hold no ':' or '=', so the first '=' and the last ':' before it split."""
    target, eq, selection = text.partition("=")
    path, colon, variant_set = target.rpartition(":")
    if not eq or not colon or not path.startswith("/") or not variant_set:
        raise ValueError(f"--variant '{text}' is not /PRIM:SET=SELECTION")
    return path, variant_set, selection


def content_hash(stage, time_code, flatten_instances=False, roots=None):
    """sha256 over every layer the stage used (file bytes; exported text for
    anonymous layers), order- and location-independent, plus the time code
    (and whether instances are flattened: a different stream), and the
    MaterialX documents read in place of layers with the files they
    XInclude (materialx_looks.py; confined to `roots` before being read)."""
    digests = []
    documents = {f for e in stage.GetCompositionErrors() for f in mtlx_error_files(str(e))}
    files = {f for d in documents for f in mtlx_document_files(d, roots)}
    for document in sorted(files):
        if os.path.isfile(document):
            with open(document, "rb") as f:
                digests.append(hashlib.sha256(f.read()).hexdigest())
    for layer in stage.GetUsedLayers():
        h = hashlib.sha256()
        real = layer.realPath
        if real and os.path.isfile(real):
            with open(real, "rb") as f:
                for block in iter(lambda: f.read(_HASH_BLOCK), b""):
                    h.update(block)
        else:
            h.update(layer.ExportToString().encode("utf-8"))
        digests.append(h.hexdigest())
    total = hashlib.sha256(READER_VERSION.encode())
    for d in sorted(digests):
        total.update(d.encode())
    total.update(repr(float(time_code)).encode())
    if flatten_instances:
        total.update(b"+flatten-instances")
    return total.hexdigest()


def variant_session_layer(variants):
    """An anonymous session layer holding `over`s with the requested variant
    selections, or None. Authored before the stage is opened, so the stage
    composes (and loads payloads) once, with the selections in force --
    also for variant sets that only exist inside another selected variant."""
    if not variants:
        return None
    layer = Sdf.Layer.CreateAnonymous("pbgi-variant-selections.usda")
    for path, variant_set, selection in variants:
        spec = Sdf.CreatePrimInLayer(layer, Sdf.Path(path))
        spec.variantSelections[variant_set] = selection
    return layer


def variant_problems(stage, variants):
    """One message per requested selection that selects nothing (no such
    prim, variant set or variant), naming what the stage has instead."""
    problems = []
    for path, variant_set, selection in variants:
        prim = stage.GetPrimAtPath(path)
        where = f"{path}: variant selection {variant_set}={selection}"
        if not prim or not prim.IsDefined():  # our own `over` alone defines nothing
            problems.append(f"{where}: no such prim")
        elif not prim.GetVariantSets().HasVariantSet(variant_set):
            names = ", ".join(prim.GetVariantSets().GetNames()) or "none"
            problems.append(f"{where}: the prim has no variant set '{variant_set}' (it has: {names})")
        else:
            names = prim.GetVariantSets().GetVariantSet(variant_set).GetVariantNames()
            if selection not in names:
                problems.append(f"{where}: not one of {', '.join(names)}")
    return problems


def open_stage(path, variants=(), roots=None):
    """Returns (stage, None) or (None, error message naming the file).
    Raises OutsideRoots if the scene uses a layer outside `roots`."""
    roots = roots or AssetRoots()
    if not os.path.exists(path):
        return None, f"cannot read scene '{path}': no such file"
    if os.path.isdir(path):
        return None, f"cannot read scene '{path}': is a directory"
    if not os.access(path, os.R_OK):
        return None, f"cannot read scene '{path}': permission denied"
    try:
        # Held while the stage composes, so that it reuses these layers.
        held = check_layer_graph(path, roots, Sdf) if roots.confined else []  # noqa: F841
        session = variant_session_layer(variants)
        if session is None:
            stage = Usd.Stage.Open(path, Usd.Stage.LoadAll)
        else:
            root = Sdf.Layer.FindOrOpen(path)
            stage = Usd.Stage.Open(root, session, Usd.Stage.LoadAll) if root else None
    except Tf.ErrorException as e:
        return None, f"cannot read scene '{path}': {_usd_error_text(e)}"
    if stage is None:
        return None, f"cannot read scene '{path}': USD could not open it"
    if roots.confined:
        check_used_layers(stage, roots)
    return stage, None


class SceneReader:
    """One traversal of a stage, writing chunks to a ChunkStream."""

    def __init__(self, stage, time, stream, max_triangles_per_chunk, draco_prims=None,
                 flatten_instances=False, roots=None):
        self.draco_prims = draco_prims or {}  # prim path -> .drc files it references
        self.roots = roots or AssetRoots()
        self.stage = stage
        self.time = time
        self.stream = stream
        self.xforms = UsdGeom.XformCache(time)
        self.materials = MaterialTable(stream, time, MaterialXLooks(stream))
        self.emitter = TriangleEmitter(stream, max_triangles_per_chunk)
        # None: instances are expanded through instance proxies (flattened).
        self.prototypes = None if flatten_instances else \
            PrototypeTable(stream, time, self.xforms, self.materials, self.emitter)

    def run(self):
        predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
        root = self.stage.GetPseudoRoot()
        self.stream.progress("counting prims", 0.0, force=True)
        total = max(1, sum(1 for _ in Usd.PrimRange(root, predicate)))
        prims = iter(Usd.PrimRange(root, predicate))
        for index, prim in enumerate(prims):
            self.stream.progress("reading prims", index / total)
            try:
                if self._read_prim(prim) == "prune":
                    prims.PruneChildren()
            except OutsideRoots:  # not a bad prim: the whole read is refused
                raise
            except Exception as e:  # one bad prim must not lose the scene
                self._prim_failed(prim, e)
        if self.prototypes is not None:
            self.prototypes.flush()
        self.stream.progress("done", 1.0, force=True)

    def _read_instance_others(self, instance):
        """Lights, cameras, volumes and PointInstancers below a native
        instance, per instance (its gprims are the prototype's)."""
        predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
        prims = iter(Usd.PrimRange(instance, predicate))
        next(prims)  # the instance itself
        for prim in prims:
            try:
                if self._read_prim(prim, geometry=False) == "prune":
                    prims.PruneChildren()
            except OutsideRoots:
                raise
            except Exception as e:
                self._prim_failed(prim, e)

    def _read_draco(self, prim, path, matrix):
        """The .drc files the prim references, as Draco MeshChunks."""
        if matrix is None:
            matrix = Gf.Matrix4d(1.0)
        for file in self.draco_prims[path]:  # checked before its bytes are read
            self.roots.check(file, f"prim {path}: a Draco file it references")
        double_sided = prim.IsA(UsdGeom.Gprim) and \
            bool(UsdGeom.Gprim(prim).GetDoubleSidedAttr().Get(self.time))
        chunks, problems = draco_chunks(path, self.draco_prims[path], matrix,
                                        self.materials.for_prim(prim), double_sided, matrix_floats)
        for chunk in chunks:
            self.stream.write(chunk)
        for problem in problems:
            self.stream.diagnostic(WARNING, path, problem, kind="draco-file")

    def _prim_failed(self, prim, error):
        if not isinstance(error, GeometryError):
            traceback.print_exc(limit=-3, file=sys.stderr)
        self.stream.diagnostic(ERROR, str(prim.GetPath()),
                               f"skipped: {type(error).__name__}: {_one_line(error)}",
                               kind="prim-failed")

    def _read_prim(self, prim, geometry=True):
        """Reads one prim; returns "prune" to skip its descendants.
        geometry=False: below a native instance, whose gprims (nested
        instances included) are its prototype's: only the rest is read."""
        if prim.IsA(UsdShade.Material) or prim.IsA(UsdShade.NodeGraph) or \
                prim.IsA(UsdShade.Shader):
            return "prune"
        if not prim.IsA(UsdGeom.Imageable):
            return None
        # Pre-order traversal with pruning makes these local checks equal to
        # ComputeVisibility/ComputePurpose (both inherit down the hierarchy)
        # without re-walking the ancestors of every prim.
        imageable = UsdGeom.Imageable(prim)
        if imageable.GetVisibilityAttr().Get(self.time) == UsdGeom.Tokens.invisible:
            return "prune"
        if not render_purpose(imageable, self.stream):
            return "prune"

        path = str(prim.GetPath())
        type_name = prim.GetTypeName()
        matrix = None
        if prim.IsA(UsdGeom.Xformable):
            matrix = self.xforms.GetLocalToWorldTransform(prim)
        if geometry and self.prototypes is not None and prim.IsInstance() and \
                not prim.IsA(UsdGeom.Gprim):
            # Native instance: its prototype's geometry once, this placement.
            if self.prototypes.place_native(prim, matrix):
                self._read_instance_others(prim)
            return "prune"
        if not geometry and (prim.IsA(UsdGeom.Gprim) or path in self.draco_prims):
            return None
        if path in self.draco_prims:
            self._read_draco(prim, path, matrix)
        if is_light(prim) and not prim.IsA(UsdGeom.Gprim):
            chunk = light_def(prim, matrix, self.time, self.stream)
            if chunk is not None:
                self.stream.write(chunk)
            return None
        if prim.IsA(UsdGeom.Camera):
            self.stream.write(camera_def(prim, matrix, self.time, self.stream))
            return None
        if prim.IsA(UsdGeom.Mesh):
            if is_light(prim):
                self.stream.diagnostic(WARNING, path, "mesh light emission is not modelled: "
                                       "read as plain geometry", kind="mesh-light")
            read_mesh(prim, matrix, self.time, self.materials, self.emitter, self.stream)
            return None
        if is_implicit(prim):
            read_implicit(prim, matrix, self.time, self.materials, self.emitter, self.stream)
            return None
        if prim.IsA(UsdGeom.PointInstancer):
            # Its prototypes are read per instance (point_instancers.py),
            # never as plain prims.
            read_point_instancer(prim, matrix, self.time, self.xforms, self.materials,
                                 self.emitter, self.stream, self.prototypes)
            return "prune"
        if prim.IsA(UsdVol.Volume):
            chunk = volume_def(prim, matrix, self.time, self.xforms, self.materials, self.stream)
            if chunk is not None:
                self.stream.write(chunk)
            return None
        if prim.IsA(UsdGeom.Gprim):  # curves, points, NURBS, tet meshes
            self.stream.diagnostic(WARNING, path, f"{type_name} is not supported yet: skipped",
                                   kind=type_name)
            return None
        if prim.IsA(UsdSkel.Root):
            self.stream.diagnostic(WARNING, path, "skinning is not applied: meshes below are "
                                   "read in their rest pose", kind=type_name)
        return None


_RENDERED_PURPOSES = ("default", "render")
_KNOWN_PURPOSES = ("default", "render", "proxy", "guide")


def render_purpose(imageable, stream):
    """True if the prim's computed purpose is default or render (what a
    final-frame renderer draws). The local value decides in the common case;
    any other value asks ComputePurpose, since an ancestor's authored
    purpose wins over the prim's own. Unknown tokens are not rendered (as
    Hydra and UsdGeom.BBoxCache do), with a WARNING."""
    local = imageable.GetPurposeAttr().Get()
    if local in _RENDERED_PURPOSES:
        return True
    computed = imageable.ComputePurpose()
    if computed not in _KNOWN_PURPOSES:
        stream.diagnostic(WARNING, str(imageable.GetPath()), f"unknown purpose '{computed}': not "
                          "a render purpose, skipped", kind="purpose")
    return computed in _RENDERED_PURPOSES


def _rendered(prim, time):
    """The traversal's pruning test (visibility, render purpose) without its
    diagnostics: what the pass before the header may use."""
    if not prim.IsA(UsdGeom.Imageable):
        return True
    imageable = UsdGeom.Imageable(prim)
    if imageable.GetVisibilityAttr().Get(time) == UsdGeom.Tokens.invisible:
        return False
    return imageable.GetPurposeAttr().Get() in _RENDERED_PURPOSES or \
        imageable.ComputePurpose() in _RENDERED_PURPOSES


def _write_header(stage, path, time, stream, flatten_instances, hash_only, roots):
    chunk = scene_pb2.SceneChunk()
    header = chunk.header
    header.source_path = stage.GetRootLayer().realPath or os.path.abspath(path)
    header.content_hash = content_hash(stage, time.GetValue(), flatten_instances, roots)
    header.meters_per_unit = UsdGeom.GetStageMetersPerUnit(stage)
    header.up_axis = str(UsdGeom.GetStageUpAxis(stage))
    header.time_code = time.GetValue()
    if not hash_only:
        # Before any cage: each cage's refinement is bounded by the surfel
        # spacing of the whole scene (server/ingest/subdivision.h).
        header.subdiv_cage_area = total_cage_area(stage, time, UsdGeom.XformCache(time),
                                                  lambda prim: _rendered(prim, time))
    stream.write(chunk)


_ASSET_IN_ERROR = re.compile(r"@([^@:]+)(?::SDF_FORMAT_ARGS[^@]*)?@")


def _report_composition_errors(stage, stream, roots):
    """Reports USD's composition errors; returns {prim path: [.drc files]}
    for the arcs to Draco files, which the traversal reads instead
    (draco_refs.py). An error about a file outside the roots (an arc that
    could not be opened) refuses the read: reported, its message would
    tell the client what exists outside."""
    draco = {}
    for error in stage.GetCompositionErrors():
        site = getattr(error, "rootSite", None)
        prim_path = str(site.path) if site is not None and hasattr(site, "path") else ""
        for asset in _ASSET_IN_ERROR.findall(str(error)):
            if os.path.isabs(asset):
                roots.check(asset, f"the file of a composition arc of {prim_path or 'the stage'}")
        files = draco_arc_files(str(error)) if prim_path.startswith("/") else []
        if files:
            draco.setdefault(prim_path, []).extend(files)
            continue
        if mtlx_error_files(str(error)):  # the Material's look is read from the document
            continue
        stream.diagnostic(WARNING, prim_path, f"composition: {_one_line(error)}")
    return draco


def main(argv):
    args = _parse_args(argv)
    out = _claim_stdout()
    if _IMPORT_ERROR is not None:
        return _fail(f"cannot import USD or the pbgi protocol ({_IMPORT_ERROR}); PYTHONPATH "
                     "must hold <build>/python and the interpreter must have usd-core", 2)

    imported = clock.monotonic()
    roots = AssetRoots(args.scene_root)
    try:
        stage, error = open_stage(args.scene, args.variants, roots)
    except OutsideRoots as e:
        return _fail(f"scene '{args.scene}' refused: {e}", EXIT_OUTSIDE_ROOTS)
    if error:
        return _fail(error, 2)
    # A selection that selects nothing is a bad request, refused before the
    # hash (so also when the daemon only asks whether the scene changed).
    bad_variants = variant_problems(stage, args.variants)
    if bad_variants:
        return _fail("; ".join(bad_variants), EXIT_BAD_SELECTION)
    opened = clock.monotonic()
    if args.time is not None:
        time = Usd.TimeCode(args.time)
    elif stage.HasAuthoredTimeCodeRange():
        time = Usd.TimeCode(stage.GetStartTimeCode())
    else:
        time = Usd.TimeCode(0.0)

    stream = ChunkStream(out, roots)
    stream.stage = stage
    try:
        _write_header(stage, args.scene, time, stream, args.flatten_instances, args.hash_only, roots)
        if args.hash_only:
            stream.end()
            out.close()
            return 0
        draco_prims = _report_composition_errors(stage, stream, roots)
        SceneReader(stage, time, stream, args.max_triangles_per_chunk, draco_prims,
                    args.flatten_instances, roots).run()
        stream.end()
        out.close()
        done = clock.monotonic()
        print(f"usd_reader: '{args.scene}': {stream.triangle_count} triangles in "
              f"{stream.chunk_count} chunks, {done - _STARTED:.2f} s (python+USD import "
              f"{imported - _STARTED:.2f} s, open {opened - imported:.2f} s, traverse "
              f"{done - opened:.2f} s)", file=sys.stderr)
    except BrokenPipeError:
        # The daemon stopped reading (cancelled or rejected the stream).
        os._exit(4)
    except OutsideRoots as e:
        return _fail(f"scene '{args.scene}' refused: {e}", EXIT_OUTSIDE_ROOTS)
    except Exception as e:
        traceback.print_exc(limit=-5, file=sys.stderr)
        return _fail(f"failed while reading scene '{args.scene}': {_one_line(e)}", 3)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
