"""Issue 27 #5: forward optical flow over the exposure (``flow`` label) against the pinhole's
analytic motion: a camera translating across the view at v moves a plane at depth z by
v·T·(v_img/z)/p pixels; a moving object's pixels by its own velocity's image; nothing moves
without motion. The camera's move is Mitsuba's own transform (checked against it)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.dataset import write_item
from spectral_cam.optics import ThinLens

from .reading import read_exr

pytestmark = pytest.mark.timeout(300)


def test_the_camera_move_is_mitsubas_subframe_transform(make_scene):
    import mitsuba as mi

    from spectral_cam.render.motion import camera_move_matrix, subframe_transform

    mi.set_variant("scalar_spectral")
    config = make_scene(motion={"camera_velocity_mps": [0.3, -0.2, 0.5], "camera_angular_velocity_dps": [20, -10, 30]},
                        exposure={"time_s": 0.05}, render={"spp": 8})
    for index in range(4):
        t = ((index + 0.5) / 4 - 0.5) * 0.05
        ours = camera_move_matrix(config, t)
        theirs = np.asarray(subframe_transform(mi, config, index, 4).matrix, dtype=np.float64).reshape(4, 4)
        np.testing.assert_allclose(ours, theirs, atol=1e-6)


def _planes(make_scene, **motion):
    return make_scene(scene={"preset": "dof_targets", "depths_m": [1.0, 2.0, 4.0]},
                      sensor={"width_px": 48, "height_px": 32}, lens={"model": "pinhole"},
                      exposure={"time_s": 0.02}, render={"spp": 4}, motion=motion)


def test_a_camera_translating_across_the_view_moves_each_plane_by_v_t_m_over_p(make_scene, tmp_path):
    velocity, exposure = 0.4, 0.02
    config = _planes(make_scene, camera_velocity_mps=[velocity, 0.0, 0.0])
    meta = write_item(config, tmp_path / "item", outputs=["depth", "flow"])
    flow, depth = read_exr(tmp_path / "item" / "flow.exr"), read_exr(tmp_path / "item" / "depth.exr")["Z"]
    lens = ThinLens.from_config(config.lens, config.sensor)
    for z in (1.0, 2.0, 4.0):
        plane = np.abs(depth - z) < 1e-3 * z
        expected = velocity * exposure * (lens.image_distance_m / z) / lens.pixel_pitch_m
        # the camera moves towards the image's left (Mitsuba's +x): the scene moves right
        np.testing.assert_allclose(flow["dx"][plane], expected, rtol=0.02)
        assert np.abs(flow["dy"][plane]).max() < 0.02 * expected
    assert meta["flow"]["camera_velocity_mps_opencv"] == [-velocity, -0.0, 0.0]


def test_a_moving_object_flows_and_the_static_world_does_not(make_scene, tmp_path):
    xml = tmp_path / "card.xml"
    xml.write_text('''<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform></sensor>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
    <shape type="rectangle" id="card"><transform name="to_world"><scale value="0.2"/><rotate y="1" angle="180"/>
        <translate z="2"/></transform></shape>
    <shape type="rectangle" id="wall"><transform name="to_world"><scale value="5"/><rotate y="1" angle="180"/>
        <translate z="6"/></transform></shape>
</scene>''')
    velocity, exposure = 0.5, 0.02
    config = make_scene(scene={"mitsuba_xml": str(xml)}, sensor={"width_px": 48, "height_px": 32},
                        lens={"model": "pinhole"}, exposure={"time_s": exposure}, render={"spp": 4},
                        motion={"object": "card", "object_velocity_mps": [0.0, velocity, 0.0]})
    meta = write_item(config, tmp_path / "item", outputs=["depth", "flow"])
    flow, depth = read_exr(tmp_path / "item" / "flow.exr"), read_exr(tmp_path / "item" / "depth.exr")["Z"]
    lens = ThinLens.from_config(config.lens, config.sensor).layout_lens
    from scipy import ndimage

    card, wall = np.abs(depth - 2.0) < 2e-3, np.abs(depth - 6.0) < 6e-3
    # the depth label and the shape map each take one ray per pixel: they may differ on the card's rim
    assert card.sum() > 20 and wall.sum() > 20 and abs(meta["flow"]["object_pixels"] - int(card.sum())) <= 0.05 * card.sum()
    card, wall = ndimage.binary_erosion(card), ndimage.binary_erosion(wall)
    expected = velocity * exposure * (lens.image_distance_m / 2.0) / lens.pixel_pitch_m
    np.testing.assert_allclose(flow["dy"][card], -expected, rtol=0.02)  # moving up: the image moves up (−y)
    assert np.abs(flow["dx"][card]).max() < 1e-6
    assert np.abs(flow["dx"][wall]).max() == 0.0 and np.abs(flow["dy"][wall]).max() == 0.0


def test_no_motion_no_flow(make_scene, tmp_path):
    write_item(_planes(make_scene), tmp_path / "item", outputs=["flow"])
    flow = read_exr(tmp_path / "item" / "flow.exr")
    assert np.abs(flow["dx"]).max() == 0.0 and np.abs(flow["dy"]).max() == 0.0
