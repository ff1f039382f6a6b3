"""The commander of the simulated PX4: modes, arming, the offboard signal, failsafes, timers.

Rules, as current PX4 applies them (../shared/reference/px4-behaviour.md):
- Boots in AUTO.LOITER, disarmed, STANDBY; arming is refused for `ready_delay_s` while
  the estimator settles ("Ready for takeoff" after about 5 s on PX4 SITL).
- Two modes are tracked, as PX4 does: the mode the user chose (`user_mode`, shown as
  CURRENT_MODE.intended_custom_mode) and the mode flying now (`nav_mode`), which differs
  during a failsafe. After a disarm the vehicle returns to the last mode the user chose
  that is not a landing or takeoff mode.
- While disarmed every real mode is accepted, OFFBOARD too. While armed, OFFBOARD needs
  the offboard signal, manual modes need RC, AUTO.MISSION needs a mission.
  AUTO.READY, AUTO.RTGS, AUTO.FOLLOW_TARGET and AUTO.PRECLAND are refused.
- The offboard signal: an accepted setpoint younger than COM_OF_LOSS_T. Lost while armed
  in OFFBOARD: the failsafe. With RC, COM_OBL_RC_ACT applies; its RC-based choices
  (Position, Altitude, Stabilized) are unavailable without RC, and NAV_RCL_ACT applies
  instead (default Return). The vehicle never goes back to OFFBOARD by itself.
- Arming: refused while not ready, with an injected failure, in OFFBOARD without the
  signal, in a manual mode without RC, in AUTO.MISSION without a mission, in AUTO.LAND
  or AUTO.RTL; DENIED while not landed. Disarming in the air is DENIED. 21196 forces.
- COM_DISARM_PRFLT: armed this long with no takeoff -> disarm. COM_DISARM_LAND: landed
  this long after a flight -> disarm.

Pure: time is passed in; what must be said on the link is queued in `events`
(('mode',), ('text', severity, text), ('mission_current', seq), ('item_reached', seq)).
"""

import math

from offboard_py import px4_modes
from offboard_py.sim import mission as missions
from offboard_py.sim import vehicle as vm

# MAV_RESULT
ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED, FAILED = 0, 1, 2, 3, 4
FORCE_MAGIC = 21196
# MAV_SEVERITY
SEV_CRITICAL, SEV_WARNING, SEV_NOTICE, SEV_INFO = 2, 4, 5, 6
# MAV_STATE
STATE_STANDBY, STATE_ACTIVE, STATE_CRITICAL = 3, 4, 5

REFUSED_MODES = frozenset(('AUTO.READY', 'AUTO.RTGS', 'AUTO.FOLLOW_TARGET', 'AUTO.PRECLAND'))
# modes the vehicle leaves for the user's previous choice once it is disarmed
TRANSIENT_MODES = frozenset(('AUTO.TAKEOFF', 'AUTO.LAND', 'AUTO.RTL', 'AUTO.PRECLAND'))
NOT_ARMABLE = frozenset(('AUTO.LAND', 'AUTO.RTL'))
# COM_OBL_RC_ACT and NAV_RCL_ACT values
OBL_ACTIONS = {0: 'POSCTL', 1: 'ALTCTL', 2: 'STABILIZED', 3: 'AUTO.RTL', 4: 'AUTO.LAND', 5: 'AUTO.LOITER',
               6: 'terminate', 7: 'disarm'}
RCL_ACTIONS = {0: 'AUTO.LOITER', 1: 'AUTO.LOITER', 2: 'AUTO.RTL', 3: 'AUTO.LAND', 4: 'AUTO.LAND',
               5: 'terminate', 6: 'disarm'}

# SET_POSITION_TARGET_LOCAL_NED
FRAME_LOCAL_NED, FRAME_BODY_NED = 1, 8
IGNORE_POSITION, IGNORE_VELOCITY, IGNORE_ACCELERATION = 0x7, 0x38, 0x1C0
FORCE_SETPOINT, IGNORE_YAW, IGNORE_YAW_RATE = 512, 1024, 2048
TAKEOFF_REACHED_M = 0.3


class SetpointRejected(ValueError):
    """A SET_POSITION_TARGET_LOCAL_NED that PX4 would not take; the message says why."""


def offboard_setpoint(frame, type_mask, position, velocity, acceleration, yaw, yaw_rate, vehicle_yaw):
    """Decode a SET_POSITION_TARGET_LOCAL_NED into a vehicle Setpoint, as PX4 reads it.

    Per-axis IGNORE bits leave an axis uncontrolled; BODY_NED rotates velocity and
    acceleration by the vehicle's yaw and ignores position. Raises SetpointRejected.
    """
    if frame not in (FRAME_LOCAL_NED, FRAME_BODY_NED):
        raise SetpointRejected('coordinate frame %d is not supported (LOCAL_NED 1 or BODY_NED 8)' % frame)
    if type_mask & FORCE_SETPOINT:
        raise SetpointRejected('force setpoints (type_mask bit 512) are not supported')
    values = list(position) + list(velocity) + list(acceleration) + [yaw, yaw_rate]
    if any(math.isinf(v) for v in values):
        raise SetpointRejected('infinite value in setpoint')
    nan = vm.NAN
    used = [float(v) if not type_mask & (1 << i) else nan for i, v in enumerate(values[:9])]
    if frame == FRAME_BODY_NED:
        c, s = math.cos(vehicle_yaw), math.sin(vehicle_yaw)
        used[0:3] = [nan, nan, nan]
        for k in (3, 6):
            x, y = used[k], used[k + 1]
            if x == x and y == y:
                used[k], used[k + 1] = c * x - s * y, s * x + c * y
    if not any(v == v for v in used):
        raise SetpointRejected('no position, velocity or acceleration in setpoint (type_mask 0x%x)' % type_mask)
    yaw_sp = float(yaw) if not type_mask & IGNORE_YAW and yaw == yaw else nan
    rate_sp = float(yaw_rate) if not type_mask & IGNORE_YAW_RATE and yaw_rate == yaw_rate else nan
    return vm.setpoint(position=used[0:3], velocity=used[3:6], acceleration=used[6:9], yaw=yaw_sp, yaw_rate=rate_sp)


class Commander:
    def __init__(self, params, vehicle, runner, now_s, ready_delay_s=5.0, rc=False):
        self.params, self.vehicle, self.runner = params, vehicle, runner
        self.boot_s = now_s
        self.ready_delay_s = ready_delay_s
        self.ready_announced = False
        self.rc = rc
        self.armed = False
        self.armed_s = None
        self.takeoff_detected = False
        self.landed_s = None
        self.failsafe = False
        self.failures = set()
        self.events = []
        self.offboard_sp = None
        self.offboard_s = None
        self.hold_point = tuple(vehicle.position)
        self.hold_yaw = vehicle.yaw
        self.takeoff_target = None
        self.land_xy = None
        self.rtl_phase = None
        self.user_mode = self.nav_mode = self.fallback_mode = 'AUTO.LOITER'

    # -- what the link reports ---------------------------------------------------------------

    def custom_mode(self):
        return px4_modes.encode(self.nav_mode)

    def intended_custom_mode(self):
        return px4_modes.encode(self.user_mode)

    def base_mode(self):
        return px4_modes.base_mode_flags(self.nav_mode, self.armed)

    def system_status(self):
        if not self.armed:
            return STATE_STANDBY
        return STATE_CRITICAL if self.failsafe else STATE_ACTIVE

    def ready(self, now_s):
        return now_s - self.boot_s >= self.ready_delay_s

    def offboard_signal(self, now_s):
        return self.offboard_s is not None and now_s - self.offboard_s <= self.params['COM_OF_LOSS_T']

    def _say(self, severity, text):
        self.events.append(('text', severity, text))

    # -- mode changes -----------------------------------------------------------------------

    def _enter(self, mode, now_s, failsafe=False):
        v = self.vehicle
        self.nav_mode = mode
        self.failsafe = failsafe
        if not failsafe:
            self.user_mode = mode
            if mode not in TRANSIENT_MODES:
                self.fallback_mode = mode
        self.hold_point = (v.position[0], v.position[1], min(v.position[2], 0.0))
        self.hold_yaw = v.yaw
        if mode == 'AUTO.LAND':
            self.land_xy = (v.position[0], v.position[1])
        elif mode == 'AUTO.RTL':
            near = math.hypot(v.position[0], v.position[1]) < self.params['RTL_MIN_DIST']
            self.rtl_phase = 'land' if near else 'climb'
        elif mode == 'AUTO.TAKEOFF' and self.takeoff_target is None:
            self.takeoff_target = (v.position[0], v.position[1], -self.params['MIS_TAKEOFF_ALT'])
        elif mode == 'AUTO.MISSION':
            self.runner.set_current(self.runner.seq if not self.runner.finished else 0)
            self.events.append(('mission_current', self.runner.seq))
        if mode != 'AUTO.TAKEOFF':
            self.takeoff_target = None
        self.events.append(('mode',))

    def request_mode(self, mode, now_s):
        """A user's mode request (SET_MODE or DO_SET_MODE); returns a MAV_RESULT."""
        if mode is None or mode in REFUSED_MODES:
            self._say(SEV_CRITICAL, 'Switching to %s is not supported' % (mode or 'an unknown mode'))
            return TEMPORARILY_REJECTED
        if mode == self.nav_mode and not self.failsafe:
            return ACCEPTED
        if self.armed:
            reason = None
            if mode == 'OFFBOARD' and not self.offboard_signal(now_s):
                reason = 'Switching to Offboard is currently not available'
            elif mode in px4_modes.MANUAL_MODES and not self.rc:
                reason = 'Switching to %s is currently not available: no manual control' % mode
            elif mode == 'AUTO.MISSION' and not self.runner.items:
                reason = 'Switching to Mission is currently not available: no valid mission'
            if reason:
                self._say(SEV_CRITICAL, reason)
                return TEMPORARILY_REJECTED
        self._enter(mode, now_s)
        return ACCEPTED

    def request_base_mode(self, base_mode, main_mode, sub_mode, now_s):
        """DO_SET_MODE / SET_MODE fields -> request_mode."""
        if base_mode & px4_modes.CUSTOM_MODE_ENABLED:
            mode = px4_modes.decode((int(main_mode) << 16) | (int(sub_mode) << 24))
        elif base_mode & px4_modes.AUTO_ENABLED:
            mode = 'AUTO.MISSION'
        elif base_mode & px4_modes.MANUAL_INPUT_ENABLED:
            if base_mode & px4_modes.GUIDED_ENABLED:
                mode = 'POSCTL'
            elif base_mode & px4_modes.STABILIZE_ENABLED:
                mode = 'STABILIZED'
            else:
                mode = 'MANUAL'
        else:
            mode = None
        return self.request_mode(mode, now_s)

    # -- arming -----------------------------------------------------------------------------

    def request_arming(self, arm, force, now_s):
        if arm:
            if self.armed:
                return ACCEPTED
            if not force:
                reason, result = self._arming_refusal(now_s)
                if reason:
                    self._say(SEV_CRITICAL, 'Arming denied: ' + reason)
                    return result
            self._arm(now_s)
            return ACCEPTED
        if not self.armed:
            return ACCEPTED
        if not force and not self.vehicle.landed:
            self._say(SEV_CRITICAL, 'Disarming denied: not landed')
            return DENIED
        self._disarm(now_s, 'commanded')
        return ACCEPTED

    def _arming_refusal(self, now_s):
        if not self.ready(now_s):
            return 'system not ready (estimator initialising)', TEMPORARILY_REJECTED
        if self.failures:
            return 'Resolve system health failures first (%s)' % ', '.join(sorted(self.failures)), \
                TEMPORARILY_REJECTED
        if self.nav_mode == 'OFFBOARD' and not self.offboard_signal(now_s):
            return 'Resolve system health failures first (no offboard signal)', TEMPORARILY_REJECTED
        if self.nav_mode in px4_modes.MANUAL_MODES and not self.rc:
            return 'no manual control', TEMPORARILY_REJECTED
        if self.nav_mode == 'AUTO.MISSION' and not self.runner.items:
            return 'no valid mission', TEMPORARILY_REJECTED
        if self.nav_mode in NOT_ARMABLE:
            return 'mode %s is not armable' % self.nav_mode, TEMPORARILY_REJECTED
        if not self.vehicle.landed:
            return 'vehicle not landed', DENIED
        return None, ACCEPTED

    def _arm(self, now_s):
        self.armed, self.armed_s = True, now_s
        self.takeoff_detected, self.landed_s = False, None
        self.vehicle.start_motors(now_s)
        self.hold_point = tuple(self.vehicle.position)
        if self.nav_mode == 'AUTO.MISSION':
            self.runner.set_current(self.runner.seq if not self.runner.finished else 0)
        self._say(SEV_INFO, 'Armed')

    def _disarm(self, now_s, why):
        self.armed = False
        self.vehicle.stop_motors()
        self.takeoff_detected, self.landed_s = False, None
        self._say(SEV_INFO, 'Disarmed (%s)' % why)
        if self.failsafe or self.nav_mode in TRANSIENT_MODES:
            mode = self.fallback_mode
            self.failsafe = False
            self._enter(mode, now_s)

    def inject_failure(self, name, failed):
        if failed:
            self.failures.add(name)
        else:
            self.failures.discard(name)

    # -- commands ---------------------------------------------------------------------------

    def takeoff(self, altitude_amsl, home_alt, now_s):
        """NAV_TAKEOFF: AUTO.TAKEOFF to the given AMSL altitude, or MIS_TAKEOFF_ALT."""
        v = self.vehicle
        height = self.params['MIS_TAKEOFF_ALT']
        if altitude_amsl == altitude_amsl and not math.isinf(altitude_amsl):
            wanted = altitude_amsl - home_alt
            if wanted > v.height() + 0.5:
                height = wanted
            else:
                self._say(SEV_WARNING, 'Takeoff altitude below the vehicle, using MIS_TAKEOFF_ALT')
        target = (v.position[0], v.position[1], -height)
        result = self.request_mode('AUTO.TAKEOFF', now_s)
        if result == ACCEPTED:
            self.takeoff_target = target
        return result

    def on_offboard_setpoint(self, sp, now_s):
        self.offboard_sp, self.offboard_s = sp, now_s

    def set_mission(self, items):
        self.runner.load(items)
        if self.nav_mode == 'AUTO.MISSION':
            self.events.append(('mission_current', 0))

    # -- the periodic update ---------------------------------------------------------------

    def tick(self, now_s, dt):
        if not self.ready_announced and self.ready(now_s):
            self.ready_announced = True
            self._say(SEV_INFO, 'Ready for takeoff!')
        self._check_offboard_loss(now_s)
        sp = self._setpoint(now_s)
        self.vehicle.step(dt, sp, now_s)
        for seq in self.runner.take_reached():
            self.events.append(('item_reached', seq))
            if not self.runner.finished:
                self.events.append(('mission_current', self.runner.seq))
        self._check_landing(now_s)

    def _check_offboard_loss(self, now_s):
        if not (self.armed and self.nav_mode == 'OFFBOARD') or self.offboard_signal(now_s):
            return
        action = OBL_ACTIONS.get(self.params['COM_OBL_RC_ACT'], 'AUTO.RTL')
        if action in ('POSCTL', 'ALTCTL', 'STABILIZED') and not self.rc:
            action = RCL_ACTIONS.get(self.params['NAV_RCL_ACT'], 'AUTO.RTL')
        self._say(SEV_CRITICAL, 'Failsafe: no offboard signal, activating %s' % action)
        if action in ('disarm', 'terminate'):  # motors off: in the air the vehicle falls
            self._disarm(now_s, 'offboard signal lost, %s' % action)
            return
        self._enter(action, now_s, failsafe=True)

    def _setpoint(self, now_s):
        v, p, mode = self.vehicle, self.params, self.nav_mode
        if mode == 'OFFBOARD' and self.offboard_sp is not None:
            return self.offboard_sp
        if mode == 'AUTO.TAKEOFF' and self.takeoff_target is not None:
            if self.armed and abs(v.position[2] - self.takeoff_target[2]) <= TAKEOFF_REACHED_M:
                self._say(SEV_INFO, 'Takeoff complete')
                self._enter('AUTO.LOITER', now_s)
                return vm.hold(self.hold_point, self.hold_yaw)
            return vm.setpoint(position=self.takeoff_target, yaw=self.hold_yaw, z_up_max=p['MPC_TKO_SPEED'])
        if mode == 'AUTO.LAND':
            return missions.land_setpoint(p, self.land_xy, v)
        if mode == 'AUTO.RTL':
            return self._rtl_setpoint()
        if mode == 'AUTO.MISSION' and self.armed:
            return self.runner.setpoint(v, now_s)
        return vm.hold(self.hold_point, self.hold_yaw)

    def _rtl_setpoint(self):
        v, p = self.vehicle, self.params
        if self.rtl_phase == 'climb':
            height = max(p['RTL_RETURN_ALT'], v.height())
            if v.height() >= height - 0.5:
                self.rtl_phase = 'return'
            return vm.setpoint(position=(self.hold_point[0], self.hold_point[1], -height), yaw=v.yaw)
        if self.rtl_phase == 'return':
            if math.hypot(v.position[0], v.position[1]) < 1.0:
                self.rtl_phase = 'land'
            return vm.setpoint(position=(0.0, 0.0, v.position[2]), yaw=v.yaw, xy_speed_max=p['MPC_XY_CRUISE'])
        return missions.land_setpoint(p, (0.0, 0.0), v)

    def _check_landing(self, now_s):
        if not self.armed:
            return
        v, p = self.vehicle, self.params
        if not v.landed:
            if not self.takeoff_detected:
                self.takeoff_detected = True
                self._say(SEV_INFO, 'Takeoff detected')
            self.landed_s = None
            return
        if not self.takeoff_detected:
            limit = p['COM_DISARM_PRFLT']
            if limit > 0 and now_s - self.armed_s >= limit:
                self._disarm(now_s, 'no takeoff within COM_DISARM_PRFLT')
            return
        if self.landed_s is None:
            self.landed_s = now_s
            self._say(SEV_INFO, 'Landing detected')
        limit = p['COM_DISARM_LAND']
        if limit >= 0 and now_s - self.landed_s >= limit:
            self._disarm(now_s, 'landed')
