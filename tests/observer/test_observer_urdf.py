"""Robots drawn from their URDF: link meshes (primitives, mesh files, the fallback box) and kinematics.

A small crane-like URDF written here (a base, a ``slew`` revolute joint about z, a ``trolley`` prismatic
joint along the jib, a ``hook`` prismatic joint down) stands in for the tower crane; pybullet_data's Husky
is the real ground robot (STL meshes, continuous wheel joints, a xacro left-over in an origin).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
import trimesh

from bimbot.services.observer.fleet_log import FleetLog, link_path, marker_path
from bimbot.services.observer.urdf_mesh import FALLBACK_RGBA, LinkMeshes, clustered
from bimbot.services.observer.urdf_model import read_urdf
from bimbot.shared.errors import InputError
from bimbot.shared.fleet import DEFAULT_FLEET_FILE, load_fleet, resolve_urdf
from bimbot.shared.messages import RobotPoseMsg, RobotState, SiteInfoMsg
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_plan import Rect, SiteLayout

MINI_CRANE = """<?xml version="1.0"?>
<robot name="mini_crane">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="base">
    <visual><origin xyz="0 0 0.5"/><geometry><box size="0.4 0.4 1.0"/></geometry>
      <material name="red"/></visual>
  </link>
  <joint name="slew" type="revolute">
    <parent link="base"/><child link="jib"/>
    <origin xyz="0 0 1.0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" effort="1" velocity="1"/>
  </joint>
  <link name="jib">
    <visual><origin xyz="1.5 0 0"/><geometry><box size="3 0.2 0.2"/></geometry>
      <material name="blue"><color rgba="0 0 1 1"/></material></visual>
  </link>
  <joint name="trolley" type="prismatic">
    <parent link="jib"/><child link="trolley_link"/>
    <origin xyz="0.5 0 -0.1"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="2.5" effort="1" velocity="1"/>
  </joint>
  <link name="trolley_link">
    <visual><geometry><cylinder radius="0.1" length="0.2"/></geometry></visual>
  </link>
  <joint name="hoist" type="prismatic">
    <parent link="trolley_link"/><child link="hook"/>
    <origin xyz="0 0 0"/><axis xyz="0 0 -1"/>
  </joint>
  <link name="hook">
    <visual><geometry><sphere radius="0.05"/></geometry></visual>
    <visual><geometry><mesh filename="meshes/hook.obj" scale="2 2 2"/></geometry></visual>
  </link>
  <joint name="cab_joint" type="fixed">
    <parent link="base"/><child link="cab"/><origin xyz="0.3 0 0.8"/>
  </joint>
  <link name="cab">
    <visual><geometry><mesh filename="meshes/missing.dae"/></geometry></visual>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.2 0.4 0.2"/></geometry></collision>
  </link>
</robot>
"""
# a unit triangle (the hook's mesh file, relative to the URDF)
HOOK_OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n"


@pytest.fixture
def crane_urdf(tmp_path: Path) -> Path:
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "hook.obj").write_text(HOOK_OBJ)
    path = tmp_path / "mini_crane.urdf"
    path.write_text(MINI_CRANE)
    return path


def _position(pose: np.ndarray) -> list[float]:
    return pose[:3, 3].tolist()


def test_the_joint_tree_is_read_root_first(crane_urdf: Path) -> None:
    model = read_urdf(crane_urdf)
    assert model.root == "base"
    order = [joint.name for joint in model.joints]
    assert order.index("slew") < order.index("trolley") < order.index("hoist")
    assert [joint.name for joint in model.moving_joints] == ["slew", "trolley", "hoist"]
    assert model.moved_links({"trolley"}) == {"trolley_link", "hook"}


def test_a_prismatic_joint_moves_its_child_by_the_value_along_its_axis(crane_urdf: Path) -> None:
    model = read_urdf(crane_urdf)
    rest = model.link_poses()
    assert _position(rest["trolley_link"]) == pytest.approx([0.5, 0.0, 0.9])
    moved = model.link_poses({"trolley": 2.0, "hoist": 0.4})
    assert _position(moved["trolley_link"]) == pytest.approx([2.5, 0.0, 0.9])
    assert _position(moved["hook"]) == pytest.approx([2.5, 0.0, 0.5])  # axis -z: hoisting lowers the hook
    assert _position(moved["cab"]) == pytest.approx([0.3, 0.0, 0.8])  # a fixed branch does not move


def test_a_revolute_joint_rotates_its_child_about_its_axis(crane_urdf: Path) -> None:
    model = read_urdf(crane_urdf)
    poses = model.link_poses({"slew": math.pi / 2, "trolley": 1.0})
    np.testing.assert_allclose(poses["jib"][:3, :3] @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-12)
    assert _position(poses["jib"]) == pytest.approx([0.0, 0.0, 1.0])
    assert _position(poses["trolley_link"]) == pytest.approx([0.0, 1.5, 0.9])


def test_primitives_and_mesh_files_become_link_meshes_in_the_link_frame(crane_urdf: Path) -> None:
    meshes = LinkMeshes().model_meshes(read_urdf(crane_urdf))
    assert set(meshes) == {"base", "jib", "trolley_link", "hook", "cab"}
    np.testing.assert_allclose(meshes["base"].bounds_m, [[-0.2, -0.2, 0.0], [0.2, 0.2, 1.0]], atol=1e-6)
    np.testing.assert_allclose(meshes["jib"].bounds_m, [[0.0, -0.1, -0.1], [3.0, 0.1, 0.1]], atol=1e-6)
    assert meshes["base"].vertex_colors[0].tolist() == [255, 0, 0, 255]  # a named material
    assert meshes["jib"].vertex_colors[0].tolist() == [0, 0, 255, 255]  # an inline colour
    hook = meshes["hook"]  # a sphere and the OBJ beside the URDF, scaled ×2
    assert hook.bounds_m[1].tolist() == pytest.approx([0.2, 0.2, 0.05], abs=1e-6)
    assert hook.triangles.max() < len(hook.vertices_m) and hook.vertex_normals.shape == hook.vertices_m.shape


def test_a_mesh_that_cannot_be_loaded_falls_back_to_the_links_box_warned_once(
    crane_urdf: Path, caplog: pytest.LogCaptureFixture
) -> None:
    model = read_urdf(crane_urdf)
    loader = LinkMeshes()
    with caplog.at_level(logging.WARNING):
        cab = loader.model_meshes(model)["cab"]
        loader.model_meshes(model)
    np.testing.assert_allclose(cab.bounds_m, [[-0.1, -0.2, 0.0], [0.1, 0.2, 0.2]], atol=1e-6)  # collision box
    assert cab.vertex_colors[0].tolist() == [round(c * 255) for c in FALLBACK_RGBA]
    assert len([r for r in caplog.records if "missing.dae" in r.getMessage()]) == 1


def test_the_husky_loads_with_its_stl_meshes_and_an_xacro_left_over() -> None:
    model = read_urdf(resolve_urdf("husky/husky.urdf"))
    assert model.root == "base_footprint"
    meshes = LinkMeshes().model_meshes(model)
    assert {"base_link", "top_plate_link", "front_left_wheel_link", "rear_bumper_link"} <= set(meshes)
    fallback = [round(c * 255) for c in FALLBACK_RGBA]
    assert all(mesh.vertex_colors[0].tolist() != fallback for mesh in meshes.values())
    assert sum(len(mesh.triangles) for mesh in meshes.values()) < 20_000  # 34 000 in its files: thinned
    wheel = meshes["front_left_wheel_link"].bounds_m
    np.testing.assert_allclose(wheel, [[-0.178, -0.057, -0.178], [0.178, 0.057, 0.178]], atol=1e-3)
    poses = model.link_poses()
    assert _position(poses["base_link"]) == pytest.approx([0.0, 0.0, 0.14493])
    # imu origin "$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)": the default values after the variable's name
    assert _position(poses["imu_link"]) == pytest.approx([0.19, 0.0, 0.14493 + 0.149])


def test_clustering_thins_a_fine_mesh_and_keeps_its_shape_and_orientation() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.2)  # 20 480 triangles
    thin = clustered(sphere, 0.01)
    assert len(thin.faces) < 0.6 * len(sphere.faces)
    np.testing.assert_allclose(thin.bounds, sphere.bounds, atol=0.01)
    outward = np.einsum("ij,ij->i", thin.face_normals, thin.triangles_center)
    assert (outward > 0).mean() > 0.99  # triangles keep their winding


@pytest.mark.parametrize("type_name", sorted(load_fleet(DEFAULT_FLEET_FILE).types))
def test_every_type_of_the_default_fleet_is_drawn_from_its_urdf(type_name: str) -> None:
    description = load_fleet(DEFAULT_FLEET_FILE).types[type_name]
    try:
        path = resolve_urdf(description.urdf)
    except InputError:
        pytest.skip(f"{description.urdf} is not written yet")
    meshes = LinkMeshes().model_meshes(read_urdf(path))
    assert meshes, type_name
    if description.crane is not None:  # slew, trolley, hoist move the crane's links
        moving = {joint.name for joint in read_urdf(path).moving_joints}
        assert {"slew", "trolley", "hoist"} <= moving


def test_read_errors_say_which_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot><link name='a'/><link name='b'/></robot>")
    with pytest.raises(InputError, match="2 root links"):
        read_urdf(bad)
    bad.write_text("<robot")
    with pytest.raises(InputError, match=r"bad\.urdf"):
        read_urdf(bad)


# --- the fleet as logged for rerun ---


def _site_info(urdf: Path) -> SiteInfoMsg:
    crane_type = DEFAULT_ROBOT.model_copy(update={"name": "mini_crane", "urdf": str(urdf)})
    layout = SiteLayout(
        building=Rect((0.0, 0.0), (1.0, 1.0)),
        yard=Rect((2.0, 0.0), (3.0, 1.0)),
        depot=Rect((4.0, 0.0), (5.0, 1.0)),
        fence=Rect((-1.0, -1.0), (6.0, 2.0)),
        slots={},
        robot_starts=((4.5, 0.5, 0.0), (4.5, 0.5, 0.0)),
    )
    return SiteInfoMsg(
        robot_ids=["r1", "r2"],
        robot_starts_xy_yaw=list(layout.robot_starts),
        robot_type_of={"r1": "mini_crane", "r2": "ghost"},
        robot_types={"mini_crane": crane_type, "ghost": DEFAULT_ROBOT.model_copy(update={"name": "ghost"})},
        step_s=0.01,
        control_period_s=0.1,
        lock_step=True,
        layout=layout,
    )


def _pose(t: float, **joints: float) -> RobotPoseMsg:
    return RobotPoseMsg(robot_id="r1", pose_xy_yaw=(0.0, 0.0, 0.0), sim_time_s=t, joint_positions=joints)


def test_each_link_mesh_is_logged_once_static_and_posed_at_time_zero(crane_urdf: Path) -> None:
    fleet = FleetLog()
    static, initial = fleet.site_known(_site_info(crane_urdf))
    crane_links = {link_path("r1", name) for name in ("base", "jib", "trolley_link", "hook", "cab")}
    crane_static = {item.entity_path for item in static if item.entity_path.startswith("world/robots/r1/")}
    assert crane_static == crane_links
    assert all(item.static and isinstance(item.archetype, rr.Mesh3D) for item in static)
    assert {item.entity_path for item in initial} >= crane_links and not any(i.static for i in initial)
    assert fleet.drawn("r1") and fleet.drawn("r2")  # r2: the default type, pybullet_data's Husky
    again, _ = fleet.site_known(_site_info(crane_urdf))
    assert again == []  # once per robot


def test_joint_values_move_only_the_links_below_the_joints_that_changed(crane_urdf: Path) -> None:
    fleet = FleetLog(pose_min_interval_s=0.1)
    fleet.site_known(_site_info(crane_urdf))
    assert fleet.robot_pose(_pose(1.0, slew=0.0, trolley=0.0, hoist=0.0)) == []  # nothing moved
    moved = fleet.robot_pose(_pose(1.1, trolley=1.0))
    assert {item.entity_path for item in moved} == {link_path("r1", "trolley_link"), link_path("r1", "hook")}
    assert all(isinstance(item.archetype, rr.Transform3D) and not item.static for item in moved)
    assert fleet.robot_pose(_pose(1.15, trolley=1.5)) == []  # too soon: held back
    ((at_s, _), *_rest) = held = fleet.flush()
    assert at_s == 1.15 and len(held) == 2  # the latest value reaches the recording in the end
    slewed = fleet.robot_pose(_pose(2.0, slew=0.5, trolley=1.5))
    assert {item.entity_path for item in slewed} == {
        link_path("r1", name) for name in ("jib", "trolley_link", "hook")
    }


def test_joint_values_heard_before_the_site_info_pose_the_links_once_it_comes(crane_urdf: Path) -> None:
    fleet = FleetLog()
    assert fleet.robot_pose(_pose(3.0, trolley=2.0)) == []  # not drawn yet: kept
    fleet.site_known(_site_info(crane_urdf))
    caught = fleet.catch_up(4.0)
    assert {item.entity_path for item in caught} == {link_path("r1", "trolley_link"), link_path("r1", "hook")}
    assert fleet.catch_up(5.0) == []


def test_the_state_of_a_drawn_robot_goes_on_its_labelled_marker(crane_urdf: Path) -> None:
    fleet = FleetLog()
    fleet.site_known(_site_info(crane_urdf))
    (marker,) = fleet.robot_state("r1", RobotState.PICK_UP)
    assert marker.entity_path == marker_path("r1")
    assert fleet.robot_state("r9", RobotState.IDLE) == []  # not on site: no model, the twin's box


def test_a_crane_erected_taller_is_drawn_with_its_hook_that_much_higher() -> None:
    """The site erected the tower crane 11 m taller than its URDF (shared/crane_erection.py): the
    dashboard draws the hook at hoist 0 and the mast's top 11 m higher, the jib unchanged."""
    urdf = resolve_urdf("tower_crane.urdf")
    as_drawn, erected = read_urdf(urdf), read_urdf(urdf, mast_raised_m=11.0)
    hook = [model.link_poses()["hook_link"][2, 3] for model in (as_drawn, erected)]
    assert hook[1] == pytest.approx(hook[0] + 11.0)
    masts = [LinkMeshes().model_meshes(model)["mast_link"].bounds_m for model in (as_drawn, erected)]
    assert masts[1][1][2] == pytest.approx(masts[0][1][2] + 11.0, abs=1e-4)
    assert masts[1][0][2] == pytest.approx(masts[0][0][2], abs=1e-4)  # it still stands on its base


def test_the_fleet_log_draws_the_crane_as_the_site_info_says_it_was_erected() -> None:
    tower = load_fleet(DEFAULT_FLEET_FILE).types["tower_crane"]
    assert tower.crane is not None
    erected = tower.model_copy(
        update={"crane": tower.crane.model_copy(update={"jib_height_m": 51.0, "mast_raised_m": 11.0})}
    )
    info = _site_info(Path("unused.urdf"))
    info = info.model_copy(
        update={
            "robot_type_of": {"r1": "tower_crane", "r2": "tower_crane"},
            "robot_types": {"tower_crane": erected},
        }
    )
    fleet = FleetLog()
    fleet.site_known(info)
    model = fleet.robot_model("r1")
    assert model is not None
    assert model.urdf.link_poses()["hook_link"][2, 3] == pytest.approx(51.0, abs=0.01)
