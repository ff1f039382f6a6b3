"""What the simulated PX4's pure modules have to say to the world, as typed events.

The commander and the navigator append these to their `events` lists; the flight stack
reacts to some (arming starts the motors, a mode change moves the navigator) and the
autopilot turns them into MAVLink (CURRENT_MODE, STATUSTEXT, MISSION_CURRENT,
MISSION_ITEM_REACHED). Nothing here sends anything.
"""

from typing import NamedTuple


class ModeChanged(NamedTuple):
    """The mode flying now (nav_mode) changed; `failsafe` when the commander chose it."""
    mode: str
    failsafe: bool


class ArmingChanged(NamedTuple):
    armed: bool
    reason: str


class StatusText(NamedTuple):
    """A message for the pilot, with its MAV_SEVERITY. `on_link` False: PX4 main says it only as an
    event (EVENT, on request), never as STATUSTEXT, so the simulator only logs it."""
    severity: int
    text: str
    on_link: bool = True


class TakeoffComplete(NamedTuple):
    """AUTO.TAKEOFF reached its altitude: the commander switches to AUTO.LOITER."""


class ReturnToLaunch(NamedTuple):
    """A mission's NAV_RETURN_TO_LAUNCH item, issued as that vehicle command to the commander (navigator's
    mission_block.cpp issue_command): the commander switches to AUTO.RTL, which ends the mission."""


class MissionCurrent(NamedTuple):
    seq: int


class ItemReached(NamedTuple):
    seq: int


class VehicleCommand(NamedTuple):
    """A command PX4's navigator publishes for another component of its own system (a gimbal, the
    mission's idle item): PX4's COMMAND_LONG stream sends it to (own system, component 0), and
    repeats it while unacknowledged when `repeat` (sim.mavlink.command_sender)."""
    command: int
    params: tuple  # param1..param7
    repeat: bool
    delay_s: float = 0.0  # after the event, when PX4's stream sends it
