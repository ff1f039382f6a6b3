"""What the simulated PX4's AUTO modes and missions share (PX4's navigator and FlightTaskAuto): PX4's
landing speeds and landing setpoint, and the Flyer that follows PX4's jerk-limited trajectory
towards a target. Pure: the vehicle model and the time are passed in.
"""

import math

from offboard_py.sim import vehicle as vm
from offboard_py.sim.trajectory import Trajectory


def dist_xy(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


def land_speed(params, height):
    """PX4's landing speed at `height` above the ground: MPC_Z_V_AUTO_DN above MPC_LAND_ALT1,
    blending to MPC_LAND_SPEED at MPC_LAND_ALT2, MPC_LAND_CRWL below MPC_LAND_ALT3 (the
    rangefinder sees the ground there)."""
    fast, slow = params['MPC_Z_V_AUTO_DN'], params['MPC_LAND_SPEED']
    alt1, alt2 = params['MPC_LAND_ALT1'], params['MPC_LAND_ALT2']
    if height >= alt1:
        speed = fast
    elif height <= alt2 or alt1 <= alt2:
        speed = slow
    else:
        speed = slow + (fast - slow) * (height - alt2) / (alt1 - alt2)
    if height < params['MPC_LAND_ALT3']:
        speed = min(speed, params['MPC_LAND_CRWL'])
    return min(speed, fast)


# Once the land detector feels the ground, PX4's landing keeps asking for more descent (its descent
# setpoint grows while the vehicle stands still: reference/conversations, takeoff-mavros-px4,
# POSITION_TARGET_LOCAL_NED at 63.5-64.5 s), which winds the thrust down to the land detector's
# minimal thrust (MINIMAL_THRUST_FRACTION, PX4's 10 %). The rate is fitted to the AUTO landings of
# reference/px4-sitl-measured.md (NAV_LAND from 2.2 m: 12.8 s; cmd/land from 5 m: 15.3 s): with it
# touchdown -> landed takes about 6 s after a slow final descent. The recorded RTL landings of the
# conversations took 3.3-3.5 s (a faster touchdown, a faster-growing setpoint); one rate cannot fit both.
LAND_PUSH_ACC = 0.03  # m/s^2
def land_setpoint(params, xy, vehicle):
    """Descend over xy at PX4's landing speeds; on the ground, push down harder (LAND_PUSH_ACC)."""
    speed = land_speed(params, vehicle.height())
    pushed_s = vehicle.ground_contact_held_s()
    if pushed_s is not None:
        speed += LAND_PUSH_ACC * pushed_s
    return vm.setpoint(position=(xy[0], xy[1], vm.NAN), velocity=(vm.NAN, vm.NAN, speed), yaw=vehicle.yaw)


class Flyer:
    """What AUTO modes share: the trajectory towards a target, restarted from the vehicle's own
    state whenever the flight stops following it (a direct setpoint came in between)."""

    def __init__(self, params):
        self.params = params
        self.trajectory = None
        self._last_s = None

    def direct(self, sp):
        """A setpoint that does not follow the trajectory."""
        self.trajectory = None
        return sp

    def fly_to(self, vehicle, target, now_s, speed_at_target=0.0, xy_speed=None, up_speed=None):
        dt = 0.0 if self._last_s is None else max(0.0, now_s - self._last_s)
        self._last_s = now_s
        if self.trajectory is None:
            self.trajectory = Trajectory(vehicle.position, vehicle.velocity)
            dt = 0.0
        t = self.trajectory
        t.step(self.params, target, dt, vehicle.position, xy_speed=xy_speed, up_speed=up_speed,
               speed_at_target=speed_at_target)
        return vm.setpoint(position=t.position, velocity=t.velocity, acceleration=t.acceleration, yaw=vehicle.yaw)

    def take_off(self, vehicle, target, now_s):
        """PX4's takeoff: straight at the target while the takeoff ramp limits the climb, then the
        trajectory at MPC_TKO_SPEED (which brakes early for a low target)."""
        if vehicle.takeoff_state != 'flight':
            return self.direct(vm.setpoint(position=target, yaw=vehicle.yaw, z_up_max=self.params['MPC_TKO_SPEED']))
        return self.fly_to(vehicle, target, now_s, up_speed=self.params['MPC_TKO_SPEED'])
