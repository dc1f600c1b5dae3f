"""Hand-written MJCF fixtures, one per MuJoCo feature; tests/mjcf_models.py re-exports them (mm.ARMATURE,
mm.FIXTURES) beside the MuJoCo reference helpers.

Every fixture is a self-contained MJCF string: no meshes, no includes, explicit `<inertial>` on every
moving body (deterministic, physically valid inertias: positive principal moments satisfying the
triangle inequality), geoms that never collide (contype = conaffinity = 0) so that no contact can appear
even when constraints are left on. All use `<compiler angle="radian">` except SPRINGS_DEGREE, which tests
MuJoCo's default (degrees). `FIXTURES` maps each constant's name to its string.
"""

#: 3-link arm, armature 0.05 from the top default (j1), 0.2 from class "geared" (j2), 0.1 explicit (j3).
ARMATURE = """
<mujoco model="armature">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
    <joint armature="0.05"/>
    <default class="geared">
      <joint armature="0.2" axis="0 1 0"/>
    </default>
  </default>
  <worldbody>
    <body name="link1" pos="0 0 0.5">
      <joint name="j1" axis="0 0 1"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="link2" pos="0.3 0 0">
        <joint name="j2" class="geared"/>
        <inertial pos="0.125 0 0" mass="0.8" diaginertia="0.0008 0.0045 0.0045"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.025"/>
        <body name="link3" pos="0.25 0 0" quat="0.9659258 0 0 0.2588190">
          <joint name="j3" class="geared" armature="0.1" pos="0 0 0.02"/>
          <inertial pos="0.1 0 0.01" quat="0.9914449 0.1305262 0 0" mass="0.5" diaginertia="0.0005 0.002 0.0022"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: Cart-double-pole: damping 2.0 explicit (slider), 0.3 from the default (hinge), 0 explicit (hinge2).
DAMPING = """
<mujoco model="damping">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
    <joint damping="0.3"/>
  </default>
  <worldbody>
    <body name="cart" pos="0 0 0.2">
      <joint name="slider" type="slide" axis="1 0 0" damping="2.0"/>
      <inertial pos="0 0 0" mass="2.0" diaginertia="0.01 0.02 0.02"/>
      <geom type="box" size="0.1 0.05 0.03"/>
      <body name="pole" pos="0 0 0">
        <joint name="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0.25" mass="0.5" diaginertia="0.0105 0.0105 0.0003"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.02"/>
        <body name="pole2" pos="0 0 0.5">
          <joint name="hinge2" axis="0 1 0" damping="0"/>
          <inertial pos="0 0 0.2" mass="0.3" diaginertia="0.004 0.004 0.0001"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.4" size="0.015"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: Springs: k=5 springref=0.3 ref=0.1 (hinge, damping 0.2); k=50 springref=-0.05 ref=0.02 (slide); k=1.5 at 0 (hinge).
SPRINGS = """
<mujoco model="springs">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="s1" pos="0 0 1">
      <joint name="k_hinge" axis="0 1 0" stiffness="5" springref="0.3" ref="0.1" damping="0.2"/>
      <inertial pos="0.2 0 0" mass="1.0" diaginertia="0.001 0.0135 0.0135"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02"/>
      <body name="s2" pos="0.4 0 0">
        <joint name="k_slide" type="slide" axis="1 0 0" stiffness="50" springref="-0.05" ref="0.02"/>
        <inertial pos="0.05 0 0" mass="0.5" diaginertia="0.0004 0.0006 0.0006"/>
        <geom type="box" size="0.05 0.02 0.02"/>
        <body name="s3" pos="0.1 0 0">
          <joint name="k_hinge2" axis="0 0 1" stiffness="1.5"/>
          <inertial pos="0.1 0.02 0" mass="0.3" diaginertia="0.0002 0.001 0.0011"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.015"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: MuJoCo's default angle unit (degree): hinge ref=10, springref=30, range=-45..45 are degrees; the slide's are metres.
SPRINGS_DEGREE = """
<mujoco model="springs_degree">
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="d1" pos="0 0 1">
      <joint name="deg_hinge" axis="0 1 0" stiffness="2" ref="10" springref="30" range="-45 45"/>
      <inertial pos="0.2 0 0" mass="1.0" diaginertia="0.001 0.0135 0.0135"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02"/>
      <body name="d2" pos="0.4 0 0">
        <joint name="deg_slide" type="slide" axis="1 0 0" stiffness="20" ref="0.1" springref="0.2" range="-0.5 0.5"/>
        <inertial pos="0 0 0" mass="0.5" diaginertia="0.0004 0.0006 0.0006"/>
        <geom type="box" size="0.05 0.02 0.02"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: Motors: gear 50 ctrllimited (mot1), gear -2.5 limited by autolimits (mot2), ctrllimited=false (mot3), a second
#: unlimited motor on joint m1 (mot1b).
MOTOR = """
<mujoco model="motor">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="mb1" pos="0 0 0.3">
      <joint name="m1" axis="0 0 1"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="mb2" pos="0.3 0 0">
        <joint name="m2" axis="0 1 0"/>
        <inertial pos="0.15 0 0" mass="0.8" diaginertia="0.0008 0.0065 0.0065"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
        <body name="mb3" pos="0.3 0 0">
          <joint name="m3" type="slide" axis="1 0 0"/>
          <inertial pos="0.05 0 0" mass="0.4" diaginertia="0.0003 0.0005 0.0005"/>
          <geom type="box" size="0.05 0.02 0.02"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="mot1" joint="m1" gear="50" ctrlrange="-1 1" ctrllimited="true"/>
    <motor name="mot2" joint="m2" gear="-2.5" ctrlrange="-3 2"/>
    <motor name="mot3" joint="m3" gear="10" ctrlrange="-1 1" ctrllimited="false"/>
    <motor name="mot1b" joint="m1" gear="5"/>
  </actuator>
</mujoco>
"""

#: Position servos: kp=100 kv=5 gear=2 ctrlrange forcerange forcelimited (pos1); kp=500 kv=0 on a slide (pos2); kp=30
#: kv=2 forcerange auto-limited, ctrl unlimited (pos3).
POSITION = """
<mujoco model="position">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="pb1" pos="0 0 0.3">
      <joint name="p1" axis="0 1 0"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="pb2" pos="0.3 0 0">
        <joint name="p2" type="slide" axis="1 0 0"/>
        <inertial pos="0.05 0 0" mass="0.6" diaginertia="0.0004 0.0007 0.0007"/>
        <geom type="box" size="0.05 0.02 0.02"/>
        <body name="pb3" pos="0.1 0 0">
          <joint name="p3" axis="0 0 1"/>
          <inertial pos="0.1 0 0" mass="0.4" diaginertia="0.0002 0.0015 0.0015"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.015"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="pos1" joint="p1" kp="100" kv="5" gear="2" ctrlrange="-1 1" forcerange="-20 20" forcelimited="true"/>
    <position name="pos2" joint="p2" kp="500" ctrlrange="-0.2 0.2"/>
    <position name="pos3" joint="p3" kp="30" kv="2" forcerange="-4 4"/>
  </actuator>
</mujoco>
"""

#: Velocity servos: kv=20 gear=3 ctrlrange (vel1); kv=4 with forcerange auto-limited (vel2).
VELOCITY = """
<mujoco model="velocity">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="vb1" pos="0 0 0.3">
      <joint name="v1" axis="0 0 1"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="vb2" pos="0.3 0 0">
        <joint name="v2" axis="0 1 0"/>
        <inertial pos="0.1 0 0" mass="0.5" diaginertia="0.0003 0.002 0.002"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.015"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity name="vel1" joint="v1" kv="20" gear="3" ctrlrange="-2 2"/>
    <velocity name="vel2" joint="v2" kv="4" forcerange="-1 1"/>
  </actuator>
</mujoco>
"""

#: General actuators: affine gain [2 0.5 -0.1], affine bias [0.3 -4 -0.7], gear 1.5, ctrl/force ranges (gen_affine);
#: fixed gain 3, no bias (gen_fixed).
GENERAL = """
<mujoco model="general">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="gb1" pos="0 0 0.3">
      <joint name="g1" axis="0 1 0"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="gb2" pos="0.3 0 0">
        <joint name="g2" type="slide" axis="0 0 1"/>
        <inertial pos="0 0 0" mass="0.5" diaginertia="0.0004 0.0004 0.0004"/>
        <geom type="box" size="0.03 0.03 0.03"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="gen_affine" joint="g1" gear="1.5" gaintype="affine" gainprm="2 0.5 -0.1"
             biastype="affine" biasprm="0.3 -4 -0.7" ctrlrange="-1 1" forcerange="-6 6"/>
    <general name="gen_fixed" joint="g2" gainprm="3"/>
  </actuator>
</mujoco>
"""

#: Gravcomp 1 (gl1), 0.5 (gl2), 0 (gl3); gj2 routes its gravcomp to qfrc_actuator (actuatorgravcomp); a free "balloon"
#: with gravcomp 1.
GRAVCOMP = """
<mujoco model="gravcomp">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="gl1" pos="0 0 1" gravcomp="1">
      <joint name="gj1" axis="0 1 0"/>
      <inertial pos="0.15 0 0.01" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="gl2" pos="0.3 0 0" gravcomp="0.5">
        <joint name="gj2" axis="0 1 0" actuatorgravcomp="true"/>
        <inertial pos="0.12 0 -0.02" mass="0.8" diaginertia="0.0008 0.004 0.004"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/>
        <body name="gl3" pos="0.25 0 0">
          <joint name="gj3" axis="1 0 1"/>
          <inertial pos="0.1 0.03 0" mass="0.5" diaginertia="0.0003 0.002 0.002"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.015"/>
        </body>
      </body>
    </body>
    <body name="balloon" pos="1 0 1" gravcomp="1">
      <freejoint name="balloon_root"/>
      <inertial pos="0.02 0 0.05" mass="0.3" diaginertia="0.002 0.002 0.003"/>
      <geom type="sphere" size="0.1"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="gmot1" joint="gj1" gear="2"/>
  </actuator>
</mujoco>
"""

#: Several joints in one body: a slide-slide-hinge planar base, a 3-hinge shoulder with a common offset anchor, a
#: 2-hinge elbow with different anchors and a non-unit axis.
MULTI_JOINT = """
<mujoco model="multi_joint">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="base" pos="0.1 -0.2 0.3" quat="0.9238795 0 0 0.3826834">
      <joint name="base_x" type="slide" axis="1 0 0"/>
      <joint name="base_y" type="slide" axis="0 1 0" ref="0.05"/>
      <joint name="base_yaw" axis="0 0 1" pos="0.05 0 0"/>
      <inertial pos="0.02 0 0" mass="3" diaginertia="0.03 0.04 0.05"/>
      <geom type="box" size="0.15 0.1 0.05"/>
      <body name="upper_arm" pos="0 0.15 0.1" quat="0.9659258 0.2588190 0 0">
        <joint name="sh_x" axis="1 0 0" pos="0 0 0.02"/>
        <joint name="sh_y" axis="0 1 0" pos="0 0 0.02"/>
        <joint name="sh_z" axis="0 0 1" pos="0 0 0.02" ref="0.2"/>
        <inertial pos="0 0 -0.15" mass="1.2" diaginertia="0.01 0.01 0.002"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
        <body name="forearm" pos="0 0 -0.3">
          <joint name="el_1" axis="0 1 0"/>
          <joint name="el_2" axis="1 1 0" pos="0.03 0 -0.05"/>
          <inertial pos="0 0 -0.12" quat="0.9961947 0 0.0871557 0" mass="0.7" diaginertia="0.005 0.005 0.001"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.025"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: World with several children: a fixed table carrying a 2-link arm (with a welded tool and a massless tcp frame), a
#: second arm on the world, a fixed pedestal.
WORLD_CHILDREN = """
<mujoco model="world_children">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="table" pos="0 0 0.7">
      <inertial pos="0 0 -0.05" mass="20" diaginertia="1 1 1.5"/>
      <geom type="box" size="0.5 0.5 0.05" pos="0 0 -0.05"/>
      <body name="left_base" pos="0 0.3 0" quat="0.7071068 0 0 0.7071068">
        <joint name="l1" axis="0 0 1"/>
        <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
        <body name="left_link" pos="0.3 0 0">
          <joint name="l2" axis="0 1 0"/>
          <inertial pos="0.125 0 0" mass="0.8" diaginertia="0.0008 0.0045 0.0045"/>
          <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/>
          <body name="left_tool" pos="0.25 0 0">
            <inertial pos="0.02 0 0" mass="0.3" diaginertia="0.0002 0.0003 0.0003"/>
            <geom type="box" size="0.02 0.02 0.02"/>
            <body name="left_tcp" pos="0.05 0 0"/>
          </body>
        </body>
      </body>
    </body>
    <body name="right_base" pos="0 -0.3 0.7" quat="0.9238795 0 0 -0.3826834">
      <joint name="r1" axis="0 0 1"/>
      <inertial pos="0.15 0 0" mass="1.1" diaginertia="0.0011 0.009 0.009"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="right_link" pos="0.3 0 0">
        <joint name="r2" axis="0 1 0"/>
        <inertial pos="0.1 0 0" mass="0.7" diaginertia="0.0007 0.0035 0.0035"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
      </body>
    </body>
    <body name="pedestal" pos="1 0 0.2">
      <inertial pos="0 0 0" mass="5" diaginertia="0.1 0.1 0.1"/>
      <geom type="cylinder" size="0.1 0.2"/>
    </body>
  </worldbody>
</mujoco>
"""

#: <option gravity="0 0 -3" timestep="0.004" integrator="Euler">: a damped pendulum (timestep is not MuJoCo's default
#: 0.002, so reading it is observable).
OPTIONS = """
<mujoco model="options">
  <compiler angle="radian"/>
  <option gravity="0 0 -3" timestep="0.004" integrator="Euler"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="bob" pos="0 0 1">
      <joint name="swing" axis="0 1 0" damping="0.1"/>
      <inertial pos="0.3 0 0" mass="1.0" diaginertia="0.001 0.001 0.001"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
    </body>
  </worldbody>
</mujoco>
"""

#: One free body (freejoint, no other joint), CoM offset from the body origin, rotated principal axes, tilted initial
#: pose; no actuators (thrust via xfrc_applied).
DRONE = """
<mujoco model="drone">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="drone" pos="0 0 1" quat="0.9961947 0 0.0871557 0">
      <freejoint name="drone_root"/>
      <inertial pos="0.005 -0.003 0.01" quat="0.9914449 0 0 0.1305262" mass="0.8" diaginertia="0.004 0.005 0.008"/>
      <geom type="box" size="0.1 0.1 0.02"/>
      <site name="rotor0" pos="0.1 0.1 0.02"/>
      <site name="rotor1" pos="-0.1 0.1 0.02"/>
      <site name="rotor2" pos="-0.1 -0.1 0.02"/>
      <site name="rotor3" pos="0.1 -0.1 0.02"/>
    </body>
  </worldbody>
</mujoco>
"""

#: Humanoid-like tree: freejoint pelvis, 2-hinge waist, 2-hinge shoulders, 3-hinge hips, knees, ankles; armature and
#: damping from defaults (class "leg" larger); motors on the upper body, position servos on the legs, velocity servos
#: on the ankles.
FLOATING_HUMANOID = """
<mujoco model="floating_humanoid">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
    <joint armature="0.02" damping="0.5"/>
    <motor ctrlrange="-1 1"/>
    <default class="leg">
      <joint armature="0.05" damping="1.0"/>
      <position kp="200" kv="10" ctrlrange="-1.5 1.5" forcerange="-150 150"/>
    </default>
  </default>
  <worldbody>
    <body name="pelvis" pos="0 0 1.0">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="8" diaginertia="0.08 0.06 0.09"/>
      <geom type="box" size="0.1 0.15 0.08"/>
      <body name="torso" pos="0 0 0.1">
        <joint name="abdomen_z" axis="0 0 1"/>
        <joint name="abdomen_y" axis="0 1 0" pos="0 0 -0.05"/>
        <inertial pos="0 0 0.2" mass="10" diaginertia="0.25 0.2 0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.4" size="0.1"/>
        <body name="head" pos="0 0 0.5">
          <inertial pos="0 0 0.05" mass="3" diaginertia="0.012 0.012 0.01"/>
          <geom type="sphere" size="0.1"/>
        </body>
        <body name="upper_arm_r" pos="0 -0.2 0.35">
          <joint name="shoulder_r1" axis="1 0 0"/>
          <joint name="shoulder_r2" axis="0 1 0"/>
          <inertial pos="0 0 -0.14" mass="1.5" diaginertia="0.011 0.011 0.002"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.28" size="0.04"/>
          <body name="lower_arm_r" pos="0 0 -0.28">
            <joint name="elbow_r" axis="0 1 0"/>
            <inertial pos="0 0 -0.12" mass="1.0" diaginertia="0.005 0.005 0.001"/>
            <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.035"/>
          </body>
        </body>
        <body name="upper_arm_l" pos="0 0.2 0.35">
          <joint name="shoulder_l1" axis="1 0 0"/>
          <joint name="shoulder_l2" axis="0 1 0"/>
          <inertial pos="0 0 -0.14" mass="1.5" diaginertia="0.011 0.011 0.002"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.28" size="0.04"/>
          <body name="lower_arm_l" pos="0 0 -0.28">
            <joint name="elbow_l" axis="0 1 0"/>
            <inertial pos="0 0 -0.12" mass="1.0" diaginertia="0.005 0.005 0.001"/>
            <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.035"/>
          </body>
        </body>
      </body>
      <body name="thigh_r" pos="0 -0.1 -0.05" childclass="leg">
        <joint name="hip_x_r" axis="1 0 0"/>
        <joint name="hip_z_r" axis="0 0 1"/>
        <joint name="hip_y_r" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="4" diaginertia="0.06 0.06 0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.06"/>
        <body name="shin_r" pos="0 0 -0.4">
          <joint name="knee_r" axis="0 -1 0"/>
          <inertial pos="0 0 -0.2" mass="2.5" diaginertia="0.035 0.035 0.005"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05"/>
          <body name="foot_r" pos="0 0 -0.4">
            <joint name="ankle_r" axis="0 1 0" armature="0.01"/>
            <inertial pos="0.04 0 -0.03" mass="0.8" diaginertia="0.001 0.003 0.003"/>
            <geom type="box" size="0.1 0.04 0.02" pos="0.04 0 -0.03"/>
          </body>
        </body>
      </body>
      <body name="thigh_l" pos="0 0.1 -0.05" childclass="leg">
        <joint name="hip_x_l" axis="1 0 0"/>
        <joint name="hip_z_l" axis="0 0 1"/>
        <joint name="hip_y_l" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="4" diaginertia="0.06 0.06 0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.06"/>
        <body name="shin_l" pos="0 0 -0.4">
          <joint name="knee_l" axis="0 -1 0"/>
          <inertial pos="0 0 -0.2" mass="2.5" diaginertia="0.035 0.035 0.005"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05"/>
          <body name="foot_l" pos="0 0 -0.4">
            <joint name="ankle_l" axis="0 1 0" armature="0.01"/>
            <inertial pos="0.04 0 -0.03" mass="0.8" diaginertia="0.001 0.003 0.003"/>
            <geom type="box" size="0.1 0.04 0.02" pos="0.04 0 -0.03"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="abdomen_z" joint="abdomen_z" gear="40"/>
    <motor name="abdomen_y" joint="abdomen_y" gear="60"/>
    <motor name="shoulder_r1" joint="shoulder_r1" gear="25"/>
    <motor name="shoulder_r2" joint="shoulder_r2" gear="25"/>
    <motor name="elbow_r" joint="elbow_r" gear="15" ctrlrange="-0.5 0.5"/>
    <motor name="shoulder_l1" joint="shoulder_l1" gear="25"/>
    <motor name="shoulder_l2" joint="shoulder_l2" gear="25"/>
    <motor name="elbow_l" joint="elbow_l" gear="15" ctrlrange="-0.5 0.5"/>
    <position name="hip_x_r" joint="hip_x_r" class="leg"/>
    <position name="hip_z_r" joint="hip_z_r" class="leg" kp="100" kv="5"/>
    <position name="hip_y_r" joint="hip_y_r" class="leg" gear="2"/>
    <position name="knee_r" joint="knee_r" class="leg" ctrlrange="-0.1 2.5"/>
    <velocity name="ankle_r" joint="ankle_r" kv="8" ctrlrange="-3 3"/>
    <position name="hip_x_l" joint="hip_x_l" class="leg"/>
    <position name="hip_z_l" joint="hip_z_l" class="leg" kp="100" kv="5"/>
    <position name="hip_y_l" joint="hip_y_l" class="leg" gear="2"/>
    <position name="knee_l" joint="knee_l" class="leg" ctrlrange="-0.1 2.5"/>
    <velocity name="ankle_l" joint="ankle_l" kv="8" ctrlrange="-3 3"/>
  </actuator>
</mujoco>
"""

#: A ball joint (anchor offset 0.05 above the body origin, armature 0.01, damping 0.2, stiffness 0.5 about the
#: identity) carrying a damped hinge.
BALL = """
<mujoco model="ball">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="ball_link" pos="0 0 1" quat="0.9659258 0 0.2588190 0">
      <joint name="ball" type="ball" pos="0 0 0.05" armature="0.01" damping="0.2" stiffness="0.5"/>
      <inertial pos="0.01 0 -0.2" mass="1.0" diaginertia="0.02 0.021 0.002"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
      <body name="ball_child" pos="0 0 -0.4">
        <joint name="ball_hinge" axis="0 1 0" damping="0.1"/>
        <inertial pos="0 0 -0.15" mass="0.5" diaginertia="0.004 0.004 0.0005"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: Joint actuatorfrcrange (common in Menagerie robots): the sum of the actuator forces on joint a1 (two motors) is
#: clamped to [-3, 3] in qfrc_actuator.
JOINT_ACTUATORFRCRANGE = """
<mujoco model="joint_actuatorfrcrange">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="ab1" pos="0 0 0.3">
      <joint name="a1" axis="0 1 0" actuatorfrcrange="-3 3"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="amot1" joint="a1" gear="2" ctrlrange="-1 1"/>
    <motor name="amot2" joint="a1" gear="1" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""

#: MuJoCo >= 3.7: actuator armature=0.001 and damping=0.002 with gear 30 add gear^2 * value (0.9 and 1.8) to the
#: joint's armature (0.01) and damping (0.1).
ACTUATOR_ARMATURE_DAMPING = """
<mujoco model="actuator_armature_damping">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="rb1" pos="0 0 0.3">
      <joint name="r1" axis="0 1 0" armature="0.01" damping="0.1"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="rmot" joint="r1" gear="30" armature="0.001" damping="0.002" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""

#: Elements warpdyn does not model (a loader should warn): fluid (density, viscosity), joint limits, frictionloss, a
#: connect inactive at the start, a fixed tendon with a spring, a muscle, a filtered position servo (activation state), a tendon
#: transmission.
UNSUPPORTED = """
<mujoco model="unsupported">
  <compiler angle="radian"/>
  <option density="1.2" viscosity="1.8e-5"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="u1" pos="0 0 1">
      <joint name="u_j1" axis="0 1 0" range="-1 1" frictionloss="0.1"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="u2" pos="0.3 0 0">
        <joint name="u_j2" axis="0 1 0" range="-1.5 1.5"/>
        <inertial pos="0.1 0 0" mass="0.5" diaginertia="0.0003 0.002 0.002"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
      </body>
    </body>
    <body name="u3" pos="0 0.5 1">
      <joint name="u_j3" axis="0 1 0"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
    </body>
  </worldbody>
  <equality>
    <connect name="couple" body1="u3" body2="u1" anchor="0 0 0" active="false"/>
  </equality>
  <tendon>
    <fixed name="t_diff" stiffness="3" damping="0.1">
      <joint joint="u_j1" coef="1"/>
      <joint joint="u_j2" coef="-1"/>
    </fixed>
  </tendon>
  <actuator>
    <muscle name="mus" joint="u_j2"/>
    <position name="filtered" joint="u_j3" kp="20" timeconst="0.05"/>
    <motor name="tendon_motor" tendon="t_diff" gear="2"/>
  </actuator>
</mujoco>
"""

#: what UNSUPPORTED carries that warpdyn does not model, element -> where it sits in the XML
UNSUPPORTED_FEATURES = {
    "fluid": "<option density='1.2' viscosity='1.8e-5'>: qfrc_fluid, part of qfrc_passive",
    "joint_limits": "u_j1, u_j2 range: limit constraints",
    "frictionloss": "u_j1 frictionloss=0.1: a friction constraint (mj_instantiateFriction), not a passive force",
    "equality": "<equality><connect active=false>: an equality constraint off at the start, which warpdyn does not enforce",
    "tendon": "<tendon><fixed t_diff> with stiffness/damping: passive tendon forces",
    "muscle": "<muscle joint=u_j2>: muscle gain/bias and activation dynamics",
    "activation": "<position timeconst=0.05>: dyntype filterexact, one act state",
    "tendon_transmission": "<motor tendon=t_diff>",
}

#: every fixture by name
FIXTURES = {
    name: value
    for name, value in dict(globals()).items()
    if name.isupper() and isinstance(value, str) and value.lstrip().startswith("<mujoco")
}

