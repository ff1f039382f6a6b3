"""PX4's MulticopterLandDetector for the simulated vehicle: ground contact, maybe landed, landed,
each a stage with PX4's hysteresis (true once its condition held for its time, false at once when it
fails), on the thrust the controller asks for and the estimated velocity. Disarmed or idling on the
ground (spool-up, waiting for a takeoff) the vehicle is landed while it rests on the ground.

As PX4's (src/modules/land_detector/MulticopterLandDetector.cpp, main 02e73e3b6f): ground contact needs low
thrust, no vertical or horizontal movement and, under climb-rate control, a commanded descent until maybe
landed; maybe landed needs minimal thrust on top of ground contact; landed, maybe landed held. Once the land
detector says ground contact, PX4's position controller commands no thrust (MulticopterPositionControl.cpp,
flying_but_ground_contact): sim.vehicle does the same, which is what brings the minimal thrust.
"""

import math

# hysteresis of each stage: land_detection_time / 3, 1 s with a valid distance to the ground (SIH's
# rangefinder near the ground). Thrust thresholds: low thrust 60 % of the range from MPC_THR_MIN to the hover
# thrust (PX4 SITL has a valid hover-thrust estimate), minimal thrust 10 %. The 10 % is what makes a takeoff
# lose maybe-landed early in the ramp: landed_state IN_AIR 1.86 and 1.98 s after an OFFBOARD arm
# (reference/conversations), and a disarm 1.9 s after the arm TEMPORARILY_REJECTED (reference/
# px4-sitl-measured.md, "Turn 3 recordings", section 6)
GROUND_CONTACT_S = MAYBE_LANDED_S = LANDED_S = 1.0 / 3.0
LOW_THRUST_FRACTION = 0.6      # of (hover - MPC_THR_MIN) above MPC_THR_MIN: "low thrust"
MINIMAL_THRUST_FRACTION = 0.1  # ... "minimal thrust" (maybe landed)
LANDED_VELOCITY_WIDENING = 2.5  # landed, the vertical-movement threshold is LNDMC_Z_VEL_MAX x this
DESCEND_MARGIN = 1.1            # a commanded descent: the velocity setpoint at least LNDMC_Z_VEL_MAX x this


class LandDetector:
    def __init__(self, landed):
        self.landed = landed
        self._reset_stages(landed)

    @property
    def maybe_landed(self):
        return self._stages['maybe'][0]

    @property
    def ground_contact(self):
        return self._stages['contact'][0]

    def contact_held_s(self, now_s, ground_contact):
        """How long ground contact has been said on the ground at now_s (s), or None while it is not."""
        state, since = self._stages['contact']
        if not (state and ground_contact) or since is None:
            return None
        return max(0.0, now_s - since - GROUND_CONTACT_S)

    def _reset_stages(self, state):
        self._stages = {name: [state, None] for name in ('contact', 'maybe', 'landed')}

    def _stage(self, name, condition, hold_s, now_s):
        stage = self._stages[name]
        if not condition:
            stage[0], stage[1] = False, None
        elif not stage[0]:
            if stage[1] is None:
                stage[1] = now_s
            stage[0] = now_s - stage[1] >= hold_s
        return stage[0]

    def update(self, vehicle, idle, now_s):
        """Landed or not after this step of `vehicle` (a VehicleModel); `idle`: disarmed or idling on
        the ground."""
        if idle:
            self.landed = vehicle.ground_contact and (self.landed or now_s - vehicle.contact_since_s >= LANDED_S)
            self._reset_stages(self.landed)
            return self.landed
        p = vehicle.params
        vel = vehicle.estimate[1]
        hover, thr_min = p['MPC_THR_HOVER'], p['MPC_THR_MIN']
        tx, ty, tz = vehicle.thrust_setpoint
        thrust = math.sqrt(tx * tx + ty * ty + tz * tz)
        low_thrust = thrust <= thr_min + (hover - thr_min) * LOW_THRUST_FRACTION
        minimal_thrust = thrust <= thr_min + (hover - thr_min) * MINIMAL_THRUST_FRACTION
        vz_sp = vehicle.velocity_setpoint[2]
        z_vel_max = p['LNDMC_Z_VEL_MAX'] * (LANDED_VELOCITY_WIDENING if self.landed else 1.0)
        still = abs(vel[2]) < z_vel_max and math.hypot(vel[0], vel[1]) <= p['LNDMC_XY_VEL_MAX']
        contact_now = low_thrust and still
        if vz_sp == vz_sp and not (self.maybe_landed or self.landed):  # climb-rate control: a commanded descent
            contact_now = contact_now and vz_sp >= DESCEND_MARGIN * p['LNDMC_Z_VEL_MAX']
        contact = self._stage('contact', contact_now, GROUND_CONTACT_S, now_s)
        maybe = self._stage('maybe', contact and minimal_thrust, MAYBE_LANDED_S, now_s)
        self.landed = self._stage('landed', maybe, LANDED_S, now_s)
        return self.landed
