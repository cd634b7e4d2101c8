"""limitray: exact Catmull-Clark limit surfaces (RenderMan semi-sharp creases), evaluation and
ray queries, from Python and numpy.

    import numpy as np, limitray
    s = limitray.Surface("mesh.obj")
    out = s.eval(face=[0, 0], u=[0.5, 0.25], v=[0.5, 0.75])   # out["p"], out["du"], out["dv"]
    hits = s.trace(origins, directions, rate=16, exact=True)

Every method releases the GIL while it works. Bad input raises ``ValueError`` (``OSError`` for
files) with the message the command-line tool prints after ``error:``.
"""

import warnings as _warnings

import numpy as np

from . import _limitray

__all__ = ["Surface", "DEFAULT_MAX_LEVEL"]

#: Default maximum isolation level of the patch table (the CLI's ``--max-level``).
DEFAULT_MAX_LEVEL = _limitray.DEFAULT_MAX_LEVEL


def _indices(name, x, n=None):
    a = np.asarray(x)
    if a.dtype.kind not in "iu" and not (a.dtype.kind == "f" and a.size == 0):
        raise TypeError(f"{name} must be integers, not {a.dtype}")
    a = np.atleast_1d(a)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, not of shape {a.shape}")
    if a.dtype.kind == "u" and a.size and a.max() > np.iinfo(np.int64).max:
        raise ValueError(f"{name}: index {a.max()} out of range")
    return np.ascontiguousarray(a, dtype=np.int64)


def _floats(name, x, dtype, shape=None):
    a = np.asarray(x)
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be numbers, not {a.dtype}")
    if shape is None:
        a = np.atleast_1d(a)
        if a.ndim != 1:
            raise ValueError(f"{name} must be one-dimensional, not of shape {a.shape}")
    elif a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must be of shape (N, 3), not {a.shape}")
    return np.ascontiguousarray(a, dtype=dtype)


def _samples(face, u, v, k):
    """``(face, k, u, v)`` of :meth:`Surface.eval` and :meth:`Surface.uv`: checked, broadcast
    to one length, contiguous."""
    face = _indices("face", face)
    n = face.shape[0]
    k = np.zeros(n, dtype=np.int64) if k is None else _indices("k", k)
    u = _floats("u", u, np.float64)
    v = _floats("v", v, np.float64)
    return tuple(np.ascontiguousarray(a) for a in np.broadcast_arrays(face, k, u, v))


class Surface:
    """The exact limit surface of a control mesh read from an OBJ file (OpenSubdiv tags).

    ``scheme`` is ``"catmark"`` or ``"loop"`` (triangles only; then ``eval``'s and
    ``trace``'s ``(u, v)`` are OpenSubdiv's triangle parameter and ``k`` is 0, as in
    ``limitray eval --scheme loop``); ``chaikin`` selects Chaikin's crease rule; ``boundary`` is
    ``None`` (the mesh's tag, else edge-and-corner), ``"none"``, ``"edge"`` or ``"corner"``;
    ``max_level`` is the patch table's maximum isolation level; ``smooth_triangles`` selects
    OpenSubdiv's smooth-triangle rule (as the mesh's ``t smoothtriangles`` tag does);
    ``surface`` replaces a Loop mesh's exact limit surface by paper 002's ``"pn"``, ``"wm"`` or
    ``"gregory"`` approximation, a Catmull-Clark mesh's by paper 004's Gregory patches
    (``"gregory"``), as ``--surface`` does. ``displace`` (``"noise:AMPLITUDE:FREQUENCY"``, as
    ``--displace``) displaces the diced surface of ``dice`` and ``trace`` along its limit
    normal (``eval`` and ``trace(exact=True)`` stay on the limit surface; the latter refuses a
    displaced surface). ``fvar`` chooses the face-varying interpolation of the texture
    coordinates (``"none"``, ``"corners-only"``, ``"corners-plus1"`` (default),
    ``"corners-plus2"``, ``"boundaries"``, ``"all"``, as ``--fvar``), which :meth:`uv`
    evaluates. Hierarchical edits in the file are honoured everywhere. The mesh
    reader's warnings are issued as Python warnings and kept in ``warnings``.
    """

    def __init__(self, path, scheme="catmark", chaikin=False, boundary=None,
                 max_level=DEFAULT_MAX_LEVEL, smooth_triangles=False, surface="exact",
                 displace=None, fvar=None):
        self._s = _limitray.Surface(str(path), scheme, bool(chaikin), boundary, int(max_level),
                                    bool(smooth_triangles), str(surface),
                                    None if displace is None else str(displace),
                                    None if fvar is None else str(fvar))
        self.path = str(path)
        for w in self._s.warnings:
            _warnings.warn(w, stacklevel=2)

    @property
    def warnings(self):
        """The mesh reader's warnings (the CLI prints them as ``warning: ...``)."""
        return list(self._s.warnings)

    @property
    def num_faces(self):
        """Number of base faces."""
        return self._s.num_faces

    @property
    def max_level(self):
        """Maximum isolation level of the patch table."""
        return self._s.max_level

    def sub_faces(self):
        """Sub-faces per base face (1 for a quad, n for an n-gon), int64 (F,)."""
        return self._s.sub_faces()

    def eval(self, face, u, v, k=None):
        """Limit position and derivatives at ``(face, k, u, v)``, exactly as ``limitray eval``.

        ``face``, ``u``, ``v`` (and ``k``, sub-face of an n-gon, default 0) are scalars or
        arrays of one length N. Returns ``{"p", "du", "dv"}``, each float64 (N, 3): the
        position and the derivatives in the (sub-)face's parameterisation.
        """
        out = self._s.eval(*_samples(face, u, v, k))
        return {"p": out[:, 0:3], "du": out[:, 3:6], "dv": out[:, 6:9]}

    def uv(self, face, u, v, k=None):
        """Limit texture coordinates at ``(face, k, u, v)``, as ``limitray trace --uv`` reports
        them: the limit of the mesh's face-varying ``vt`` values in the ``fvar`` mode given to
        the constructor (default ``corners-plus1``). Arguments as in :meth:`eval`. Returns
        ``{"st", "du", "dv"}``, each float64 (N, 2): the coordinates and their derivatives in
        the (sub-)face's ``u`` and ``v``. A mesh without texture coordinates raises ValueError.
        """
        m = self._s.uv(*_samples(face, u, v, k))
        return {"st": m[:, 0:2], "du": m[:, 2:4], "dv": m[:, 4:6]}

    def trace(self, origins, directions, rate=16, exact=False, shading_normals=True):
        """Closest hits of rays (``origins``, ``directions``: (N, 3)) on the limit surface
        diced ``rate`` segments per face edge, as ``limitray trace``: the diced surface is
        traced with the rays rounded to float32 (like the CLI).

        With ``exact``, the reference intersector answers instead (as ``limitray trace
        --exact``): the certified first hit on the exact limit surface for the rays as given
        in float64, whatever ``rate``. Returns ``{"hit": bool (N,), "t", "face",
        "k", "u", "v": (N,), "n": (N, 3)}``: float64 values (diced hits are float32 values,
        widened exactly), face and k int64; a miss has t = inf, face = k = -1, u, v, n = nan.
        With ``exact`` the dict also has ``"err"``: float64 (N,), a bound on the distance of
        ``o + t d`` from the exact surface relative to the bounding-box diagonal (NaN for
        certain misses, the graze distance for grazing misses), ``"sharp"``: bool (N,), hits on
        infinitely sharp features, and ``"grazing"``: bool (N,), rays that touch the surface
        tangentially within ``err``. The BVH of each rate is built once
        and kept.

        With ``shading_normals=False`` the diced surface is built for tracing alone (no
        vertex normals: a faster build and less memory, as ``limitray bench
        --no-shading-normals``): the hits are the same, bit for bit, and ``"n"`` is the unit
        geometric normal of the diced triangle hit instead of the interpolated limit normal.
        It does not change ``exact`` traces, whose normal is the exact surface's.
        """
        o = _floats("origins", origins, np.float64, shape=3)
        d = _floats("directions", directions, np.float64, shape=3)
        if o.shape != d.shape:
            raise ValueError(f"origins {o.shape} and directions {d.shape} differ in shape")
        return self._s.trace(o, d, int(rate), bool(exact), bool(shading_normals))

    def refine(self, level, limit=False):
        """Uniform refinement to ``level``, as ``limitray refine --level``.

        Returns ``(vertices, faces)``: float64 (V, 3) control points of the level (with
        ``limit``, their exact limit positions), and int64 (F, n) vertex indices when every
        face has n vertices (always, from level 1 on), else a list of int64 arrays. Hole faces
        are left out.
        """
        pos, offsets, verts, warnings = self._s.refine(int(level), bool(limit))
        for w in warnings:
            _warnings.warn(w, stacklevel=2)
        sizes = np.diff(offsets)
        if sizes.size and np.all(sizes == sizes[0]):
            faces = verts.reshape(-1, int(sizes[0]))
        elif sizes.size == 0:
            faces = np.zeros((0, 4), dtype=np.int64)
        else:
            faces = [verts[a:b] for a, b in zip(offsets[:-1], offsets[1:])]
        return pos, faces

    def dice(self, rate=16):
        """The limit surface diced into crack-free triangles, as ``limitray dice --rate``.

        Returns ``(vertices, triangles, params)``: float32 (V, 3) limit points, int64 (T, 3)
        counter-clockwise triangles, and ``params`` = ``{"face", "k": int64 (V,), "u", "v":
        float64 (V,), "n": float32 (V, 3)}``, the domain point that evaluated each vertex and
        its unit limit normal.
        """
        pos, nrm, tri, params = self._s.dice(int(rate))
        params["n"] = nrm
        return pos, tri, params

    def __repr__(self):
        return f"limitray.Surface({self.path!r}, {self.num_faces} faces)"
