"""warpdyn's Warp kernels and `@wp.func` helpers, one algorithm per module, each built per scalar type.

Every module exposes `kernels(scalar)` (cached) returning a namespace of kernels for wp.float32 or
wp.float64. Conventions are in `spatial`. Arrays with a leading environment axis are indexed
[env, ...]; their physical layout is chosen by the façade (see warpdyn._arrays).
"""
