"""The engine: what launches kernels and owns their workspaces and recorded launches.

Modules here import the types (warpdyn.types), the array layout (warpdyn.arrays) and the kernels
(warpdyn.kernels), never the public API above them.
"""
