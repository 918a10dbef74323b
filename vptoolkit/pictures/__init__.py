"""Pictures of meshes seen through the measures' camera, and what is made of them.

One concept per module:

* :mod:`~vptoolkit.pictures.shading`: what both engines share: ``RenderStyle``,
  crease-aware normals, the picture camera, framing, the light, a model's
  own colours and sRGB;
* :mod:`~vptoolkit.pictures.engine`: the ``Engine`` protocol,
  ``open_renderer`` (engine by name) and ``drawing_engine`` (the one engine
  every picture function takes, or the default made for the call);
* :mod:`~vptoolkit.pictures.software_engine`: ``SoftwareRenderer``, the
  measures' rasteriser with numpy shading (the default engine);
* :mod:`~vptoolkit.pictures.open3d_engine`: ``Renderer``, Open3D's Filament
  in a child process (its wire protocol and main loop are the private
  ``_open3d_child``);
* :mod:`~vptoolkit.pictures.views`: pictures from given, best or predicted
  directions;
* :mod:`~vptoolkit.pictures.png`: PNG encoding and atomic writing;
* :mod:`~vptoolkit.pictures.sphere_map`: quality over the view sphere as a
  Mercator map;
* :mod:`~vptoolkit.pictures.sphere_panels`: every measure's map on one
  figure, a grid of panels;
* :mod:`~vptoolkit.pictures.contact_sheet`: a view set as one captioned picture;
* :mod:`~vptoolkit.pictures.thumbnails`: a thumbnail per mesh of a folder;
* :mod:`~vptoolkit.pictures.thumbnail_index`: the paged HTML index of a
  folder's thumbnails;
* :mod:`~vptoolkit.pictures.report`: the static HTML report of a dataset.

Import from the modules; this package itself imports nothing, so the Open3D
render child, which imports ``_open3d_child``, starts without loading the
rest. Everything needs numpy alone at import; matplotlib (maps, sheets) and
Open3D (in the child) are imported where they are used.
"""
