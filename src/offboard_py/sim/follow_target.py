"""AUTO.FOLLOW_TARGET of the simulated PX4, as PX4's follow-me flies it (src/modules/flight_mode_manager/tasks/
AutoFollowTarget/FlightTaskAutoFollowTarget.cpp and its follow_target_estimator/TargetEstimator.cpp, main 02e73e3b6f):

- the target is what FOLLOW_TARGET messages say (mavlink_receiver.cpp handle_message_follow_target: position and
  velocity); the estimate runs on at the target's velocity between messages, and holds still once no message came
  for GPS_MESSAGE_STALE_TIMEOUT_MS;
- the estimate goes through a second-order filter (TARGET_POS_VEL_FILTER_*) before it is followed;
- the vehicle follows FLW_TGT_DST away at the follow angle FLW_TGT_FA from the target's course (180: behind; the
  course kept while the target is slower than TARGET_SPEED_DEADZONE_FOR_ORIENTATION_TRACKING), the angle turning no
  faster than FLW_TGT_MAX_VEL along the circle; FLW_TGT_HT above home (FLW_TGT_ALT_M 0, the constant mode);
- while more than ALT_ACCEPTANCE_THRESHOLD from that height it only climbs or descends where it is; then the follow
  position, with the target's velocity as feed-forward; it faces the target beyond
  MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL; without a target it holds where it is.
Left out: the stick adjustments of distance, height and angle, the gimbal, the emergency ascent near the ground,
the orbit's jerk and acceleration limits. Pure: time and the vehicle are passed in.
"""

import math

from offboard_py.sim import vehicle as vm
from offboard_py.sim.flight_math import wrap_pi

STALE_S = 3.0                # GPS_MESSAGE_STALE_TIMEOUT_MS
FILTER_WN, FILTER_ZETA = 1.0, 0.7071  # TARGET_POS_VEL_FILTER_NATURAL_FREQUENCY, _DAMPING_RATIO
COURSE_MIN_SPEED = 1.0       # TARGET_SPEED_DEADZONE_FOR_ORIENTATION_TRACKING, m/s
ALT_ACCEPTANCE_M = 3.0       # ALT_ACCEPTANCE_THRESHOLD
YAW_MIN_DISTANCE_M = 1.0     # MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL


class FollowTarget:
    """The target as PX4's follow-me knows it, and the setpoint that follows it."""

    def __init__(self):
        self.measured = None   # (time s, position NED, velocity NED) of the last FOLLOW_TARGET
        self.filtered = None   # [position, velocity] of the second-order filter
        self.course = None     # rad from north: the target's course
        self.orbit = None      # rad: where around the target the vehicle is asked to be
        self.last_s = None

    def on_target(self, position, velocity, now_s):
        self.measured = (now_s, tuple(position), tuple(velocity))

    def reset(self):
        """The mode begins: the filter and the orbit start again from the next estimate."""
        self.filtered = self.course = self.orbit = self.last_s = None

    def estimate(self, now_s):
        """(position, velocity) NED of the target now, or None without one."""
        if self.measured is None:
            return None
        t, position, velocity = self.measured
        age = now_s - t
        if age > STALE_S:
            return position, (0.0, 0.0, 0.0)
        return tuple(p + v * age for p, v in zip(position, velocity)), velocity

    def _filter(self, position, velocity, dt):
        if self.filtered is None or dt <= 0.0:
            self.filtered = [list(position), list(velocity)]
            return
        pos, vel = self.filtered
        for i in (0, 1, 2):
            acc = FILTER_WN * FILTER_WN * (position[i] - pos[i]) + 2.0 * FILTER_ZETA * FILTER_WN * (velocity[i] - vel[i])
            vel[i] += acc * dt
            pos[i] += vel[i] * dt

    def setpoint(self, vehicle, home, params, now_s):
        here = vehicle.estimate[0]
        target = self.estimate(now_s)
        if target is None:  # "Target estimate is invalid: Stay in current position": no position, velocity 0
            return vm.setpoint(velocity=(0.0, 0.0, 0.0), yaw=vehicle.yaw)
        dt = 0.0 if self.last_s is None else now_s - self.last_s
        self.last_s = now_s
        self._filter(target[0], target[1], dt)
        position, velocity = self.filtered
        distance = params['FLW_TGT_DST']
        follow_angle = math.radians(params['FLW_TGT_FA'])
        if math.hypot(velocity[0], velocity[1]) >= COURSE_MIN_SPEED and math.hypot(*target[1][:2]) >= COURSE_MIN_SPEED:
            self.course = math.atan2(velocity[1], velocity[0])
        to_target = (position[0] - here[0], position[1] - here[1])
        if self.course is None:  # no course yet: where the vehicle is around the target, less the follow angle
            self.course = wrap_pi(math.atan2(-to_target[1], -to_target[0]) - follow_angle)
        wanted = self.course + follow_angle
        if self.orbit is None:
            self.orbit = wrap_pi(wanted)
        max_step = params['FLW_TGT_MAX_VEL'] / max(distance, 1e-3) * dt
        self.orbit += max(-max_step, min(max_step, wrap_pi(wanted - self.orbit)))
        desired = (position[0] + distance * math.cos(self.orbit), position[1] + distance * math.sin(self.orbit),
                   home[2] - params['FLW_TGT_HT'])
        yaw = math.atan2(to_target[1], to_target[0]) if math.hypot(*to_target) > YAW_MIN_DISTANCE_M else vehicle.yaw
        if abs(desired[2] - here[2]) >= ALT_ACCEPTANCE_M:
            return vm.setpoint(position=(here[0], here[1], desired[2]), yaw=yaw)
        return vm.setpoint(position=desired, velocity=(velocity[0], velocity[1], vm.NAN), yaw=yaw)
