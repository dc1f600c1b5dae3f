"""The types: the model and its one parameter registry, the settings of a step, the terrains, the
enumerations, the collidable points' parameters. Modules here import the description (host parsing), the
array layout and the kernels, never the engine or the public API above them.
"""
