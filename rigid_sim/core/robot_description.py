# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""URDF and SDFormat models of one link, as body entries of the scene format.

A Gazebo user spawns a model: a URDF ``<robot>`` or an SDFormat ``<model>``. rigid_sim has
no joints yet, so a model of exactly one link is served, and a model of more is refused
naming how many links it has. The link becomes a body entry (the mapping an item of a
scene's ``bodies:`` is), which the scene loader then checks like any other, and its centre
of mass, which the scene format takes from the shape but a model gives in ``<inertial>``:

- mass and inertia from ``<inertial>``, the tensor turned from the inertial frame into the
  link's axes (I_link = R I R^T), the centre of mass at the inertial frame's origin; a link
  without ``<inertial>`` is refused (nothing is guessed);
- the shape from the one ``<collision>`` geometry (else the one ``<visual>``): box,
  sphere, cylinder (axis z in all three formats) or mesh; a geometry away from the link
  frame is refused, as a scene's shape is centred on its body frame;
- the body frame is the link frame: SDFormat's model and link poses place it, a URDF's
  single link is at the model frame.

XML is read without a DTD (no entities: nothing outside the text is pulled in) and without
the network; a refusal names the line and column or the element, never the text found.
URDF is parsed by yourdfpy; SDFormat, whose single-link subset is small, by lxml here.
"""
import io
import os
from urllib.parse import unquote, urlparse

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.scene_file import confined, FileRefused, not_found

# SimulatorFeatures.spawn_formats: what SpawnEntity reads.
SPAWN_FORMATS = ('rigid_sim_yaml', 'urdf', 'sdf')
# File name endings of the formats; a file without one is recognised by its first element.
SUFFIXES = {'.urdf': 'urdf', '.sdf': 'sdf', '.yaml': 'rigid_sim_yaml',
            '.yml': 'rigid_sim_yaml'}
# Formats a client may mean that are not served, by ending and by root element.
UNSERVED = {'.xacro': 'xacro', '.usd': 'usd', '.usda': 'usd', '.usdc': 'usd',
            '.mjcf': 'mjcf', '.world': 'an SDFormat world'}
ROOTS = {'robot': 'urdf', 'sdf': 'sdf', 'mujoco': 'mjcf', 'COLLADA': 'collada'}
# The environment variable Gazebo looks up model:// URIs in (directories of model folders).
MODEL_PATH_VARIABLE = 'GZ_SIM_RESOURCE_PATH'


class DescriptionRefused(ValueError):
    """A model that is not spawned: ``kind`` 'parse', 'unsupported' or 'missing_asset'."""

    def __init__(self, kind, reason):
        super().__init__(reason)
        self.kind = kind


def spawn_format(text, file_name=''):
    """Return which of SPAWN_FORMATS ``text`` (from ``file_name``, if a file) is in.

    The file name's ending decides when it has a known one; else text starting with ``<``
    is XML, told by its root element, and anything else is the scene format (YAML).

    Raises
    ------
    DescriptionRefused
        'unsupported' for a format that is not served (xacro, USD, MJCF, a world), naming it.
    """
    suffix = os.path.splitext(file_name)[1].lower()
    if suffix in UNSERVED:
        _unserved(UNSERVED[suffix])
    if suffix in SUFFIXES:
        return SUFFIXES[suffix]
    if not text.lstrip().startswith('<'):
        return 'rigid_sim_yaml'
    tag = parse_xml(text).tag
    if tag not in ROOTS or ROOTS[tag] not in SPAWN_FORMATS:
        _unserved(ROOTS.get(tag, 'XML of another kind than URDF or SDFormat'))
    return ROOTS[tag]


def _unserved(what):
    raise DescriptionRefused('unsupported', f'{what} is not served; spawn_formats are '
                                            f'{list(SPAWN_FORMATS)}')


def parse_xml(text):
    """Return the root element of the XML ``text``, read with no DTD, entities or network."""
    from lxml import etree
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False,
                             huge_tree=False, remove_comments=True, remove_pis=True)
    try:
        root = etree.fromstring(text.encode('utf-8'), parser)
    except etree.XMLSyntaxError as error:
        line, column = error.position
        # lxml's words quote the text (tag names, characters): only the position is told.
        raise DescriptionRefused('parse', f'line {line}, column {column}: not well-formed '
                                          'XML') from None
    if root.getroottree().docinfo.doctype:
        raise DescriptionRefused('parse', 'a DOCTYPE is not read (no entities, no DTD)')
    return root


def model_body(text, spawn_format_name, resolve):
    """Return the body entry and centre of mass of the one-link model ``text``.

    Parameters
    ----------
    text : str
        URDF or SDFormat XML.
    spawn_format_name : str
        'urdf' or 'sdf'.
    resolve : callable
        A mesh's URI or path -> the path to read (see :func:`resource_candidates`); raises
        DescriptionRefused('missing_asset').

    Returns
    -------
    entry : dict
        A body entry of the scene format: name (the model's), shape, mass, inertia (given,
        link axes) and pose (of the link frame in the model's parent frame).
    center_of_mass : (3,) float
        m, link frame.

    Raises
    ------
    DescriptionRefused
    """
    if spawn_format_name == 'urdf':
        return _urdf_body(text, resolve)
    return _sdf_body(text, resolve)


def _urdf_body(text, resolve):
    parse_xml(text)   # refuses a DTD before yourdfpy's own parser reads the text
    import yourdfpy   # imported when used: it loads trimesh's scene machinery
    try:
        robot = yourdfpy.URDF.load(
            io.BytesIO(text.encode('utf-8')), build_scene_graph=False, load_meshes=False,
            build_collision_scene_graph=False, load_collision_meshes=False,
            filename_handler=lambda fname: fname).robot
    except Exception as error:  # noqa: B902  its parser's words may quote the text
        raise DescriptionRefused('parse', f'URDF: an element lacks an attribute or a value '
                                          f'is no number ({type(error).__name__})') from None
    if len(robot.links) != 1:
        raise DescriptionRefused('parse', _links_refusal('URDF', robot.name, len(robot.links)))
    link = robot.links[0]
    where = f'URDF link {link.name!r}'
    inertial = link.inertial
    if inertial is None or inertial.mass is None or inertial.inertia is None:
        raise DescriptionRefused('parse', f'{where}: no <inertial> with mass and inertia (a '
                                          'body needs both; none is guessed)')
    shape = _one_geometry(link.collisions, link.visuals, where, _urdf_shape, resolve)
    frame = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, float)
    entry = {'name': robot.name, 'shape': shape, 'mass': float(inertial.mass),
             'inertia': {'matrix': _turned(frame[:3, :3], inertial.inertia)}}
    return entry, frame[:3, 3].copy()


def _links_refusal(what, name, count):
    return (f'{what} model {name!r} has {count} links: rigid_sim simulates free bodies '
            'without joints, so a model of exactly one link is spawned')


def _one_geometry(collisions, visuals, where, shape_of, resolve):
    """Return the shape of the one collision (else visual) geometry of a link."""
    elements = collisions or visuals
    kind = 'collision' if collisions else 'visual'
    if len(elements) != 1:
        raise DescriptionRefused('parse', f'{where}: {len(elements)} {kind} geometries; a '
                                          'body has exactly one shape')
    return shape_of(elements[0], where, resolve)


def _urdf_shape(element, where, resolve):
    if element.origin is not None and not np.allclose(element.origin, np.eye(4)):
        _offset_refusal(where)
    geometry = element.geometry
    if geometry is None:
        raise DescriptionRefused('parse', f'{where}: a geometry without a shape')
    if geometry.box is not None:
        return {'type': 'box', 'size': np.asarray(geometry.box.size, float).tolist()}
    if geometry.sphere is not None:
        return {'type': 'sphere', 'radius': float(geometry.sphere.radius)}
    if geometry.cylinder is not None:
        return {'type': 'cylinder', 'radius': float(geometry.cylinder.radius),
                'length': float(geometry.cylinder.length)}
    if geometry.mesh is not None:
        scale = geometry.mesh.scale
        return {'type': 'mesh', 'file': resolve(geometry.mesh.filename),
                'scale': 1.0 if scale is None else np.broadcast_to(
                    np.asarray(scale, float), 3).tolist()}
    raise DescriptionRefused('unsupported', f'{where}: a geometry other than box, sphere, '
                                            'cylinder or mesh')


def _offset_refusal(where):
    raise DescriptionRefused('parse', f'{where}: the geometry is placed away from the link '
                                      "frame; a body's shape is centred on its frame (move "
                                      'the link frame to it)')


def _turned(rotation, inertia):
    """Turn the inertia tensor given in axes ``rotation`` into the link's axes."""
    return (rotation @ np.asarray(inertia, float) @ rotation.T).tolist()


def _sdf_body(text, resolve):
    root = parse_xml(text)
    if root.find('world') is not None:
        _unserved('an SDFormat <world>')
    models = root.findall('model')
    if len(models) != 1:
        raise DescriptionRefused('parse', f'SDFormat: {len(models)} <model> elements; one is '
                                          'spawned')
    model = models[0]
    name = model.get('name', '')
    if _text(model, 'static') in ('true', '1'):
        raise DescriptionRefused('parse', f'SDFormat model {name!r} is static: rigid_sim '
                                          'has no fixed bodies, every body moves')
    for unserved in ('include', 'model', 'joint'):
        if model.find(unserved) is not None:
            raise DescriptionRefused('parse', f'SDFormat model {name!r}: <{unserved}> is not '
                                              'served (one link, no joints)')
    links = model.findall('link')
    if len(links) != 1:
        raise DescriptionRefused('parse', _links_refusal('SDFormat', name, len(links)))
    link = links[0]
    where = f'SDFormat link {link.get("name", "")!r}'
    if _text(link, 'gravity') in ('false', '0'):
        raise DescriptionRefused('parse', f'{where}: <gravity>false</gravity>: the scene\'s '
                                          'gravity acts on every body')
    inertial = link.find('inertial')
    if inertial is None or inertial.find('mass') is None or inertial.find('inertia') is None:
        raise DescriptionRefused('parse', f'{where}: no <inertial> with <mass> and <inertia> '
                                          '(a body needs both; none is guessed)')
    frame = _pose(inertial, where)
    shape = _one_geometry(link.findall('collision'), link.findall('visual'), where,
                          _sdf_shape, resolve)
    placed = _pose(model, f'SDFormat model {name!r}') @ _pose(link, where)
    entry = {'name': name, 'shape': shape,
             'mass': _number(inertial.find('mass'), where),
             'inertia': {'matrix': _turned(frame[:3, :3], _sdf_inertia(inertial, where))},
             'pose': {'position': placed[:3, 3].tolist(),
                      'orientation': Rotation.from_matrix(placed[:3, :3]).as_quat().tolist()}}
    return entry, frame[:3, 3].copy()


def _text(element, tag):
    found = element.find(tag)
    return None if found is None or found.text is None else found.text.strip()


def _numbers(element, count, where):
    """Return the ``count`` numbers an element holds, or refuse naming the element."""
    try:
        values = [float(item) for item in (element.text or '').split()]
    except ValueError:
        values = []
    if len(values) != count or not np.all(np.isfinite(values)):
        raise DescriptionRefused('parse', f'{where}: <{element.tag}> (line '
                                          f'{element.sourceline}) must hold {count} finite '
                                          'numbers')
    return values


def _number(element, where):
    return _numbers(element, 1, where)[0]


def _pose(element, where):
    """Return the 4x4 transform of an element's ``<pose>`` (x y z roll pitch yaw), or eye(4)."""
    pose = element.find('pose')
    if pose is None:
        return np.eye(4)
    if pose.get('relative_to') or pose.get('rotation_format', 'euler_rpy') != 'euler_rpy' \
            or pose.get('degrees', 'false') not in ('false', '0'):
        raise DescriptionRefused('parse', f'{where}: <pose> (line {pose.sourceline}) with '
                                          'relative_to, degrees or a rotation_format is not '
                                          'served: x y z roll pitch yaw in radians, '
                                          'relative to the parent')
    x, y, z, roll, pitch, yaw = _numbers(pose, 6, where)
    frame = np.eye(4)
    # Fixed axes x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll), as SDFormat and URDF define rpy.
    frame[:3, :3] = Rotation.from_euler('xyz', [roll, pitch, yaw]).as_matrix()
    frame[:3, 3] = [x, y, z]
    return frame


def _sdf_inertia(inertial, where):
    tensor = inertial.find('inertia')
    value = {}
    for name, default in (('ixx', None), ('iyy', None), ('izz', None), ('ixy', 0.0),
                          ('ixz', 0.0), ('iyz', 0.0)):
        element = tensor.find(name)
        if element is None and default is None:
            raise DescriptionRefused('parse', f'{where}: <inertia> has no <{name}>')
        value[name] = default if element is None else _number(element, where)
    return [[value['ixx'], value['ixy'], value['ixz']],
            [value['ixy'], value['iyy'], value['iyz']],
            [value['ixz'], value['iyz'], value['izz']]]


def _sdf_shape(element, where, resolve):
    if element.find('pose') is not None and not np.allclose(_pose(element, where), np.eye(4)):
        _offset_refusal(where)
    geometry = element.find('geometry')
    shapes = [] if geometry is None else list(geometry)
    if len(shapes) != 1:
        raise DescriptionRefused('parse', f'{where}: a <geometry> holds exactly one shape')
    shape = shapes[0]
    if shape.tag == 'box':
        return {'type': 'box', 'size': _numbers(_child(shape, 'size', where), 3, where)}
    if shape.tag == 'sphere':
        return {'type': 'sphere', 'radius': _number(_child(shape, 'radius', where), where)}
    if shape.tag == 'cylinder':
        return {'type': 'cylinder',
                'radius': _number(_child(shape, 'radius', where), where),
                'length': _number(_child(shape, 'length', where), where)}
    if shape.tag == 'mesh':
        scale = shape.find('scale')
        return {'type': 'mesh', 'file': resolve(_text(shape, 'uri') or ''),
                'scale': 1.0 if scale is None else _numbers(scale, 3, where)}
    raise DescriptionRefused('unsupported', f'{where}: geometry <{shape.tag}> (line '
                                            f'{shape.sourceline}) is not served: box, sphere, '
                                            'cylinder or mesh')


def _child(element, tag, where):
    found = element.find(tag)
    if found is None:
        raise DescriptionRefused('parse', f'{where}: <{element.tag}> (line '
                                          f'{element.sourceline}) has no <{tag}>')
    return found


def resource_candidates(uri, base_dir, roots, package_share=None):
    """Paths a resource ``uri`` may name, most specific first.

    Parameters
    ----------
    uri : str
        A path (relative ones start at ``base_dir``), ``file://``, ``package://<package>/
        <path>`` or ``model://<model>/<path>``.
    base_dir : str
        Where a relative path starts.
    roots : sequence of str
        The allowed directories: ``package://p/x`` is also looked for as ``<root>/p/x`` and
        ``model://m/x`` as ``<root>/m/x`` in each (and in each directory of
        ``GZ_SIM_RESOURCE_PATH``; what is read must still lie in a root).
    package_share : callable or None
        Package name -> its share directory or None (the ament index, where there is one).

    Raises
    ------
    DescriptionRefused
        'unsupported' for another scheme (http, ...).
    """
    parsed = urlparse(uri)
    rest = unquote(parsed.netloc + parsed.path)
    if parsed.scheme == 'file':
        return [unquote(parsed.path)]
    if parsed.scheme in ('package', 'model'):
        head, _, tail = rest.partition('/')
        folders = list(roots or ())
        if parsed.scheme == 'package':
            share = package_share(head) if package_share is not None else None
            candidates = [os.path.join(share, tail)] if share else []
        else:
            candidates = []
            folders += [folder for folder in os.environ.get(MODEL_PATH_VARIABLE, '').split(
                os.pathsep) if folder]
        return candidates + [os.path.join(folder, head, tail) for folder in folders]
    if parsed.scheme and len(parsed.scheme) > 1:   # not a Windows drive letter
        raise DescriptionRefused('unsupported', f'uri scheme {parsed.scheme[:20]!r} is not '
                                                'served: a path, file://, package:// or '
                                                'model://')
    return [os.path.join(base_dir, uri)]


def find_resource(uri, base_dir, roots, what, package_share=None):
    """Return the real path of the first of :func:`resource_candidates` allowed.

    Raises DescriptionRefused('missing_asset') with the same words whether nothing exists
    there or it lies outside the allowed directories.
    """
    for candidate in resource_candidates(uri, base_dir, roots, package_share):
        try:
            return confined(candidate, roots, what)
        except FileRefused:
            continue
    raise DescriptionRefused('missing_asset', not_found(what, roots or ()))
