"""MAV_CMD_INJECT_FAILURE in the simulated PX4: which of PX4 SITL's modules takes each failure unit, and
what it does. PX4 (main 02e73e3b6f) forwards the command only with SYS_FAILURE_EN 1 (mavlink_receiver.cpp:
DENIED otherwise) and acknowledges nothing itself; the module that takes the unit answers (ACCEPTED or
UNSUPPORTED), and a unit no module takes gets no COMMAND_ACK at all.

The simulated PX4 stands for PX4 SITL as the PX4 tutorial runs it, with Gazebo Classic, where
SimulatorMavlink (src/modules/simulation/simulator_mavlink/SimulatorMavlink.cpp check_failure_injections)
takes the sensor units: GPS OFF stops the GPS messages (sim.estimator: EKF2 loses the position after
EKF2_NOAID_TOUT, the modes that need it fall back), STUCK and WRONG are accepted with the sensor marked
failed; the other sensors (gyro, accel, mag, baro, airspeed, VIO) OFF/OK mark their sensor failed or good,
which stops arming. PX4 SITL SIH, which the cross-stack tier runs, has no SimulatorMavlink: there a sensor
failure goes unanswered and nothing happens (reference/px4-sitl-measured.md, "Turn 4 recordings", item 6).
The battery unit is battery_simulator's (sim.battery_simulator, on SIH too). Motors are commander's
FailureInjector, not modelled here: UNSUPPORTED. RC signal, MAVLink signal, servos, avoidance: no module.
"""

from offboard_py.dialect import FAILURE_TYPE_OFF, FAILURE_TYPE_OK, mavlink

GPS = mavlink.FAILURE_UNIT_SENSOR_GPS
BATTERY = mavlink.FAILURE_UNIT_SYSTEM_BATTERY
MOTOR = mavlink.FAILURE_UNIT_SYSTEM_MOTOR
# SimulatorMavlink's sensor units besides GPS
SENSORS = {mavlink.FAILURE_UNIT_SENSOR_GYRO: 'gyro', mavlink.FAILURE_UNIT_SENSOR_ACCEL: 'accel',
           mavlink.FAILURE_UNIT_SENSOR_MAG: 'mag', mavlink.FAILURE_UNIT_SENSOR_BARO: 'baro',
           mavlink.FAILURE_UNIT_SENSOR_AIRSPEED: 'airspeed', mavlink.FAILURE_UNIT_SENSOR_VIO: 'vio'}
GPS_TYPES = (FAILURE_TYPE_OFF, FAILURE_TYPE_OK, mavlink.FAILURE_TYPE_STUCK, mavlink.FAILURE_TYPE_WRONG)


def inject(flight, unit, failure_type, instance, now_s):
    """The failure on `flight` (sim.flight.Flight): True ACCEPTED, False UNSUPPORTED, None unanswered."""
    if unit == BATTERY:
        return flight.battery.inject(failure_type, instance)
    if unit == GPS:
        if failure_type not in GPS_TYPES:
            return False
        if failure_type == FAILURE_TYPE_OFF:
            flight.vehicle.estimator.gps_off(now_s)
        elif failure_type == FAILURE_TYPE_OK:
            flight.vehicle.estimator.gps_on(now_s)
        flight.commander.inject_failure('gps', failure_type not in (FAILURE_TYPE_OK, FAILURE_TYPE_OFF))
        return True
    if unit in SENSORS:
        if failure_type not in (FAILURE_TYPE_OFF, FAILURE_TYPE_OK):
            return False
        flight.commander.inject_failure(SENSORS[unit], failure_type == FAILURE_TYPE_OFF)
        return True
    if unit == MOTOR:
        return False
    return None
