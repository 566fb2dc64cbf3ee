"""The tutorial's pipeline on the Mitsuba side: a tutorial scene file becomes a Mitsuba XML
scene, and a render of it becomes the tutorial's image.

- :mod:`.model`: the model chooser (path depth, samples, blob tessellation) against an
  error target;
- :mod:`.xml`: the XML writer (plugins, ``<default>`` values, the ``codermind-tutorial``
  block);
- :mod:`.convert`: ``codermind convert`` as a function (choose, write atomically);
- :mod:`.image`: the image pipeline (exposure, tone curve, sRGB, 2x2 mean, TGA bytes);
- :mod:`.render`: rendering a converted scene in passes and applying that pipeline.

The scene files are parsed by the caller (the command line uses the port's parser): this
package reads the parsed scene's attributes and imports nothing above it.
"""
