"""The import paths of lutbake's former flat layout for its public names (``from lutbake.plan import Axis``):
lutbake/__init__.py appends this folder to the package's ``__path__``, so ``lutbake.plan`` resolves here
and warns once where the name lives now."""
