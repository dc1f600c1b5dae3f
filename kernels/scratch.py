"""Per-link records of a kernel's scratch, kept as scalar columns, and 6D reads of scalar arrays.

A dynamics kernel keeps what one pass over the links hands to a later pass in one scalar array of logical
shape (N, nL, K): K numbers per link, named by column offsets in the kernel's docstring. On a GPU the
façade lays it out as (nL, K, N) (warpdyn._arrays, environment fastest), so the 32 threads of a warp read
and write 32 neighbouring numbers; an array of structs (a mat66 is 144 bytes per link) would instead make
every thread touch its own 144-byte run, and the warp many cache lines per load.

Symmetric 6x6 matrices keep their upper triangle, row by row (21 numbers); transforms their translation
then their quaternion (x, y, z, w) (7 numbers). The same records as vectors (`pack_transform`, `pack_sym66` and
their inverses) serve a kernel that keeps them in its thread's local memory (kernels/fused_step.py).
"""

import types

import warp as wp

from .factory import factory
from .spatial import spatial

SYM66 = 21
"""Numbers of a symmetric 6x6 matrix's upper triangle."""
TRANSFORM = 7
"""Numbers of a transform: translation, quaternion (x, y, z, w)."""


@factory
def scratch(scalar) -> types.SimpleNamespace:
    """Readers and writers of per-link records in `scalar` (wp.float32 or wp.float64)."""
    sp = spatial(scalar)
    vec7 = wp.types.vector(TRANSFORM, scalar)
    vec21 = wp.types.vector(SYM66, scalar)

    @wp.func
    def get6(a: wp.array3d(dtype=scalar), env: int, i: int, col: int):
        """The vec6 a[env, i, col:col + 6]."""
        return sp.vec6(a[env, i, col], a[env, i, col + 1], a[env, i, col + 2], a[env, i, col + 3], a[env, i, col + 4], a[env, i, col + 5])

    @wp.func
    def put6(a: wp.array3d(dtype=scalar), env: int, i: int, col: int, x: sp.vec6):
        """a[env, i, col:col + 6] = x."""
        for r in range(6):
            a[env, i, col + r] = x[r]

    @wp.func
    def row6(a: wp.array2d(dtype=scalar), env: int, col: int):
        """The vec6 a[env, col:col + 6] of a (N, K) array."""
        return sp.vec6(a[env, col], a[env, col + 1], a[env, col + 2], a[env, col + 3], a[env, col + 4], a[env, col + 5])

    @wp.func
    def get_transform(a: wp.array3d(dtype=scalar), env: int, i: int, col: int):
        """The transform stored at a[env, i, col:col + 7]."""
        return sp.transform(
            sp.vec3(a[env, i, col], a[env, i, col + 1], a[env, i, col + 2]),
            sp.quat(a[env, i, col + 3], a[env, i, col + 4], a[env, i, col + 5], a[env, i, col + 6]),
        )

    @wp.func
    def put_transform(a: wp.array3d(dtype=scalar), env: int, i: int, col: int, X: sp.transform):
        """a[env, i, col:col + 7] = (translation, quaternion xyzw) of X."""
        p = wp.transform_get_translation(X)
        q = wp.transform_get_rotation(X)
        for r in range(3):
            a[env, i, col + r] = p[r]
        for r in range(4):
            a[env, i, col + 3 + r] = q[r]

    @wp.func
    def get_sym66(a: wp.array3d(dtype=scalar), env: int, i: int, col: int):
        """The symmetric mat66 whose upper triangle is a[env, i, col:col + 21], row by row."""
        m00 = a[env, i, col + 0]
        m01 = a[env, i, col + 1]
        m02 = a[env, i, col + 2]
        m03 = a[env, i, col + 3]
        m04 = a[env, i, col + 4]
        m05 = a[env, i, col + 5]
        m11 = a[env, i, col + 6]
        m12 = a[env, i, col + 7]
        m13 = a[env, i, col + 8]
        m14 = a[env, i, col + 9]
        m15 = a[env, i, col + 10]
        m22 = a[env, i, col + 11]
        m23 = a[env, i, col + 12]
        m24 = a[env, i, col + 13]
        m25 = a[env, i, col + 14]
        m33 = a[env, i, col + 15]
        m34 = a[env, i, col + 16]
        m35 = a[env, i, col + 17]
        m44 = a[env, i, col + 18]
        m45 = a[env, i, col + 19]
        m55 = a[env, i, col + 20]
        return sp.mat66(
            m00, m01, m02, m03, m04, m05,
            m01, m11, m12, m13, m14, m15,
            m02, m12, m22, m23, m24, m25,
            m03, m13, m23, m33, m34, m35,
            m04, m14, m24, m34, m44, m45,
            m05, m15, m25, m35, m45, m55,
        )  # fmt: skip

    @wp.func
    def put_sym66(a: wp.array3d(dtype=scalar), env: int, i: int, col: int, M: sp.mat66):
        """a[env, i, col:col + 21] = the upper triangle of M, row by row (M symmetric)."""
        a[env, i, col + 0] = M[0, 0]
        a[env, i, col + 1] = M[0, 1]
        a[env, i, col + 2] = M[0, 2]
        a[env, i, col + 3] = M[0, 3]
        a[env, i, col + 4] = M[0, 4]
        a[env, i, col + 5] = M[0, 5]
        a[env, i, col + 6] = M[1, 1]
        a[env, i, col + 7] = M[1, 2]
        a[env, i, col + 8] = M[1, 3]
        a[env, i, col + 9] = M[1, 4]
        a[env, i, col + 10] = M[1, 5]
        a[env, i, col + 11] = M[2, 2]
        a[env, i, col + 12] = M[2, 3]
        a[env, i, col + 13] = M[2, 4]
        a[env, i, col + 14] = M[2, 5]
        a[env, i, col + 15] = M[3, 3]
        a[env, i, col + 16] = M[3, 4]
        a[env, i, col + 17] = M[3, 5]
        a[env, i, col + 18] = M[4, 4]
        a[env, i, col + 19] = M[4, 5]
        a[env, i, col + 20] = M[5, 5]

    @wp.func
    def pack_transform(X: sp.transform):
        """X's record as a vector: translation, quaternion (x, y, z, w)."""
        p = wp.transform_get_translation(X)
        q = wp.transform_get_rotation(X)
        return vec7(p[0], p[1], p[2], q[0], q[1], q[2], q[3])

    @wp.func
    def unpack_transform(r: vec7):
        """The transform of the record r (`pack_transform`)."""
        return sp.transform(sp.vec3(r[0], r[1], r[2]), sp.quat(r[3], r[4], r[5], r[6]))

    @wp.func
    def pack_sym66(M: sp.mat66):
        """The record of a symmetric M as a vector: its upper triangle, row by row."""
        return vec21(
            M[0, 0], M[0, 1], M[0, 2], M[0, 3], M[0, 4], M[0, 5], M[1, 1], M[1, 2], M[1, 3], M[1, 4], M[1, 5],
            M[2, 2], M[2, 3], M[2, 4], M[2, 5], M[3, 3], M[3, 4], M[3, 5], M[4, 4], M[4, 5], M[5, 5],
        )  # fmt: skip

    @wp.func
    def unpack_sym66(a: vec21):
        """The symmetric mat66 of the record a (`pack_sym66`)."""
        return sp.mat66(
            a[0], a[1], a[2], a[3], a[4], a[5],
            a[1], a[6], a[7], a[8], a[9], a[10],
            a[2], a[7], a[11], a[12], a[13], a[14],
            a[3], a[8], a[12], a[15], a[16], a[17],
            a[4], a[9], a[13], a[16], a[18], a[19],
            a[5], a[10], a[14], a[17], a[19], a[20],
        )  # fmt: skip

    @wp.func
    def sym_upper(M: sp.mat66):
        """The symmetric mat66 with M's upper triangle: only those 21 entries of M's expression are computed."""
        return sp.mat66(
            M[0, 0], M[0, 1], M[0, 2], M[0, 3], M[0, 4], M[0, 5],
            M[0, 1], M[1, 1], M[1, 2], M[1, 3], M[1, 4], M[1, 5],
            M[0, 2], M[1, 2], M[2, 2], M[2, 3], M[2, 4], M[2, 5],
            M[0, 3], M[1, 3], M[2, 3], M[3, 3], M[3, 4], M[3, 5],
            M[0, 4], M[1, 4], M[2, 4], M[3, 4], M[4, 4], M[4, 5],
            M[0, 5], M[1, 5], M[2, 5], M[3, 5], M[4, 5], M[5, 5],
        )  # fmt: skip

    return types.SimpleNamespace(
        sym_upper=sym_upper,
        get6=get6,
        put6=put6,
        row6=row6,
        get_transform=get_transform,
        put_transform=put_transform,
        get_sym66=get_sym66,
        put_sym66=put_sym66,
        pack_transform=pack_transform,
        unpack_transform=unpack_transform,
        pack_sym66=pack_sym66,
        unpack_sym66=unpack_sym66,
    )
