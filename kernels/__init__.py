"""warpdyn's Warp kernels and `@wp.func` helpers, one algorithm per module, each built per scalar type.

Every module exposes `kernels(scalar)` (cached) returning a namespace of kernels for wp.float32 or
wp.float64. Conventions are in `spatial`; kernels take the typed bundles of `bundles` (the model, the
state, the controls, targets, terrain, contacts). Arrays with a leading environment axis are indexed
[env, ...]; their physical layout is chosen by warpdyn.arrays. Nothing here imports warpdyn but
warpdyn.engine.warp_private (the C++ names of Warp's types), which imports nothing of warpdyn.

Tape discipline (what keeps wp.Tape gradients right in Warp 1.19):
- every output and scratch element is written once per launch; later iterations may read it;
- no local is carried across iterations of a dynamic loop (sums over children use sibling chains,
  see rnea.py); loops with constant bounds are unrolled and may accumulate;
- never reuse a local name across an unrolled loop and a later dynamic loop (Warp then treats it as
  loop-carried and the adjoint of the first loop reads the later value).
"""
