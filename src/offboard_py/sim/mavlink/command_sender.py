"""The simulated PX4's command sender and its delayed answers, as PX4's MavlinkCommandSender
(src/modules/mavlink/mavlink_command_sender.cpp) sends the vehicle's own commands, repeating each until
acknowledged, and as its MAVLink module answers a command a few ms after the request (the COMMAND_ACK of
the commander's result on the module's next cycles).

`deferred` holds (clock time due, link, message) in order; the loop (sim.loop) wakes for the earliest."""

from offboard_py.dialect import mavlink

# PX4 SITL's ACKs come a few ms after the request and after what it sent for it (PROTOCOL_VERSION,
# AVAILABLE_MODES: about 4 ms later; reference/px4-sitl-measured.md, "Turn 3 recordings", sections 3-4)
ACK_DELAY_S = 0.004
# PX4's MavlinkCommandSender repeats a command it sent until acknowledged: recorded at +1.01, +1.53 and
# +2.04 s after the first, with confirmation 1, 2, 3 (reference/conversations, COMMAND_LONG 1001 and 0)
COMMAND_REPEATS_S = (1.01, 1.53, 2.04)


class CommandSender:
    """The deferred messages of one simulated PX4: its ACKs and its own commands on `links`."""

    def __init__(self, clock, mav, system_id, links):
        self.clock, self.mav, self.system_id, self.links = clock, mav, system_id, links
        self.deferred = []  # (clock time due, link, message): answers that PX4 sends a few ms later

    def ack(self, link, msg, command, result, delay_s=ACK_DELAY_S):
        """COMMAND_ACK on `link`, the request's, `delay_s` (simulated) after now: PX4's commander and
        streams answer on the MAVLink module's next cycles, a few ms after what the request sent."""
        ack = self.mav.command_ack_encode(command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())
        if delay_s <= 0:
            link.send(ack)
        else:
            self.deferred.append((self.clock() + delay_s, link, ack))

    def send_deferred(self, now=None):
        """What is due of the deferred answers (their clock times), in their order."""
        if not self.deferred:
            return
        now = self.clock() if now is None else now
        due = [d for d in self.deferred if d[0] <= now]
        if due:
            self.deferred = [d for d in self.deferred if d[0] > now]
            for _, link, msg in due:
                link.send(msg)

    def send_vehicle_command(self, event):
        """A command of the navigator's, as PX4's COMMAND_LONG stream sends it on every link: to its own
        system, component 0 (MAV_COMP_ID_ALL), after `delay_s`, repeated while unacknowledged."""
        first = self.clock() + event.delay_s
        sends = [(first, 0)]
        if event.repeat:
            sends += [(first + after, i) for i, after in enumerate(COMMAND_REPEATS_S, 1)]
        for due, confirmation in sends:
            msg = self.mav.command_long_encode(self.system_id, mavlink.MAV_COMP_ID_ALL, event.command, confirmation,
                                               *event.params)
            for link in self.links:
                self.deferred.append((due, link, msg))

    def on_command_ack(self, msg):
        """An answer to a command we sent: PX4's command sender stops repeating it."""
        self.deferred = [d for d in self.deferred if not (d[2].get_type() == 'COMMAND_LONG'
                                                          and d[2].command == msg.command and d[2].confirmation)]
