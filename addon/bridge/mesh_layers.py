# SPDX-License-Identifier: GPL-3.0-or-later
"""TexSynth's own layers on a mesh (its UV map and corner attributes, core/layers.py): written atomically,
snapshotted so a failed write or an undo puts them back exactly, and cleared. Foreign layers are never
touched."""

from ..core.finite import FiniteScan
from ..core.layers import (ATTRIBUTE_NAMES, BASE_UV_NAME, GROUPS_NAME, SET_ATTRIBUTE_NAMES, WEIGHTS_NAME,
                           check_uv_capacity, is_texsynth_uv_name)
from ..core.settings import SettingsError
from .mesh_io import MeshWriteError, fail_point, read_uv, snapshot_attribute


def texsynth_uv_names(mesh):
    return [layer.name for layer in mesh.uv_layers if is_texsynth_uv_name(layer.name)]


def check_capacity(mesh):
    check_uv_capacity([layer.name for layer in mesh.uv_layers])


def snapshot(mesh, reuse=None):
    """Everything write_result/clear may change, to restore it exactly. A live update takes it on
    the main thread while the synthesizer runs in a worker (mesh reads overlap the native work).
    reuse: an older snapshot no longer needed, whose buffers are filled again where sizes match
    (it is invalid afterwards)."""
    num_corners = len(mesh.loops)
    old_attributes = reuse["attributes"] if reuse is not None else {}
    old_uv = reuse["uv"] if reuse is not None else {}
    attributes = {}
    for name in ATTRIBUTE_NAMES:
        attribute = mesh.attributes.get(name)
        old = old_attributes.get(name)
        attributes[name] = (snapshot_attribute(attribute, old[3] if old is not None else None)
                            if attribute is not None else None)
    active_color = getattr(mesh.attributes, "active_color", None)
    return {
        "uv_order": [layer.name for layer in mesh.uv_layers],
        "uv": {layer.name: read_uv(layer, num_corners, old_uv.get(layer.name)) for layer in mesh.uv_layers
               if is_texsynth_uv_name(layer.name)},
        "active_uv": mesh.uv_layers.active_index,
        "render_uv": next((i for i, layer in enumerate(mesh.uv_layers) if layer.active_render), -1),
        "attributes": attributes,
        "active_color": active_color.name if active_color is not None else None,
    }


def _restore(mesh, snapshot):
    """Puts back TexSynth's layers exactly as in snapshot (foreign layers are never touched)."""
    # By name, looked up each time: removing a layer invalidates references to the other layers.
    for name in [name for name in texsynth_uv_names(mesh) if name not in snapshot["uv"]]:
        mesh.uv_layers.remove(mesh.uv_layers[name])
    for name, values in snapshot["uv"].items():
        layer = mesh.uv_layers.get(name) or mesh.uv_layers.new(name=name, do_init=False)
        layer.data.foreach_set("uv", values)
    _restore_uv_order_flags(mesh, snapshot)
    for name, saved in snapshot["attributes"].items():
        attribute = mesh.attributes.get(name)
        if attribute is not None and saved is None:
            mesh.attributes.remove(attribute)
        elif saved is not None:
            data_type, domain, key, values = saved
            if attribute is None or attribute.data_type != data_type or attribute.domain != domain:
                if attribute is not None:
                    mesh.attributes.remove(attribute)
                attribute = mesh.attributes.new(name, data_type, domain)
            attribute.data.foreach_set(key, values)
    if snapshot["active_color"] is not None and hasattr(mesh.attributes, "active_color"):
        attribute = mesh.attributes.get(snapshot["active_color"])
        if attribute is not None:
            mesh.attributes.active_color = attribute
    mesh.update()


def _restore_uv_order_flags(mesh, snapshot):
    """Active and render UV maps as in snapshot, by name (indices shift when older TexSynth maps go);
    a flag on a removed map falls back to the first map."""
    names = [layer.name for layer in mesh.uv_layers]
    # Set only when different: each assignment is an RNA update (a few ms per live update).
    for key, apply in (("active_uv", lambda i: mesh.uv_layers.active_index != i
                        and setattr(mesh.uv_layers, "active_index", i)),
                       ("render_uv", lambda i: not mesh.uv_layers[i].active_render
                        and setattr(mesh.uv_layers[i], "active_render", True))):
        index = snapshot[key]
        if 0 <= index < len(snapshot["uv_order"]) and names:
            name = snapshot["uv_order"][index]
            apply(names.index(name) if name in names else 0)


def write_layers(mesh, base, colors, extras, scan_during_write, taken_snapshot=None):
    """Writes TexSynth's base UV map (`base`, flat float32 u, v per corner) and its corner attributes
    (`colors`: FLOAT_COLOR, `extras`: FLOAT, {name: flat float32}, names from core.layers); every other
    TexSynth corner attribute and older blend-set UV maps are removed. Foreign UV maps keep their data
    and flags; the active/render UV map is not changed unless the mesh had none.

    Raises SettingsError or MeshWriteError after restoring the mesh as it was; returns the snapshot taken
    before writing, for restore(). scan_during_write: the values are scanned for NaN/inf in a worker
    thread while the layers are written (the caller checked only shapes and dtypes). taken_snapshot:
    snapshot(mesh) taken since the mesh last changed (else it is taken here)."""
    saved = taken_snapshot if taken_snapshot is not None else snapshot(mesh)
    had_uv = len(mesh.uv_layers) > 0
    # Every value written is scanned (the weights after their in-place RGBA conversion: 1 - w is
    # finite exactly when w is); nothing below changes these arrays.
    scan = FiniteScan([("base_uv", base)] + list(colors.items()) + list(extras.items())) \
        if scan_during_write else None
    try:
        layer = mesh.uv_layers.get(BASE_UV_NAME) or mesh.uv_layers.new(name=BASE_UV_NAME,
                                                                                 do_init=False)
        if layer is None:
            raise MeshWriteError("Blender refused to create UV map %r" % BASE_UV_NAME)
        layer.data.foreach_set("uv", base)
        fail_point("uv_layer")
        wanted = dict((name, ("FLOAT_COLOR", "color", values)) for name, values in colors.items())
        wanted.update((name, ("FLOAT", "value", values)) for name, values in extras.items())
        # Every TexSynth corner attribute is rewritten or removed (stale ones of another run/method go).
        for name in ATTRIBUTE_NAMES:
            attribute = mesh.attributes.get(name)
            data_type, key, values = wanted.get(name, (None, None, None))
            if attribute is not None and (data_type is None or attribute.data_type != data_type
                                          or attribute.domain != "CORNER"):
                mesh.attributes.remove(attribute)
                attribute = None
            if data_type is not None:
                if attribute is None:
                    attribute = mesh.attributes.new(name, data_type, "CORNER")
                attribute.data.foreach_set(key, values)
                fail_point({WEIGHTS_NAME: "weights", GROUPS_NAME: "weights"}.get(
                    name, "sets" if name in SET_ATTRIBUTE_NAMES else "extras"))
        if scan is not None:
            bad, scan = scan.wait(), None
            if bad is not None:
                raise SettingsError("native result %s contains NaN or infinite values (mesh restored)" % bad)
        # Last: removed layers would come back in another order if a later step failed.
        _remove_uv_layers(mesh, [n for n in texsynth_uv_names(mesh) if n != BASE_UV_NAME])
        if had_uv:
            _restore_uv_order_flags(mesh, saved)
        else:
            mesh.uv_layers.active_index = 0
            mesh.uv_layers[0].active_render = True
        mesh.update()
    except Exception as error:
        if scan is not None:
            scan.wait()  # no thread left reading the arrays
        _restore(mesh, saved)
        if isinstance(error, (SettingsError, MeshWriteError)):
            raise
        raise MeshWriteError("writing TexSynth layers failed (mesh restored): %s" % error) from error
    return saved


def restore(mesh, snapshot):
    """Undoes a successful write_result (its returned snapshot): the mesh is as before it."""
    _restore(mesh, snapshot)


def _remove_uv_layers(mesh, names):
    for name in names:
        layer = mesh.uv_layers.get(name)
        if layer is not None:
            mesh.uv_layers.remove(layer)


def clear(mesh):
    """Removes every TexSynth UV layer and the weight attribute (and nothing else); returns the count."""
    names = texsynth_uv_names(mesh)
    active_name = mesh.uv_layers.active.name if mesh.uv_layers.active else None
    _remove_uv_layers(mesh, names)
    removed = len(names)
    for name in ATTRIBUTE_NAMES:
        attribute = mesh.attributes.get(name)
        if attribute is not None:
            mesh.attributes.remove(attribute)
            removed += 1
    if active_name is not None and mesh.uv_layers.get(active_name) is not None:
        mesh.uv_layers.active_index = list(mesh.uv_layers.keys()).index(active_name)
    if removed:
        mesh.update()
    return removed
