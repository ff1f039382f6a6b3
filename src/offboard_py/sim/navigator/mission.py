"""AUTO.MISSION, as PX4's navigator/mission.cpp: fly the mission items (sim.mission_runner), reporting reached
items."""

from offboard_py.sim import events as ev
from offboard_py.sim.navigator.navigator_mode import NavigatorMode


class MissionMode(NavigatorMode):
    """AUTO.MISSION: fly the mission's items (MissionRunner), reporting those reached."""

    def on_activation(self):
        nav = self.nav
        nav.mission.restart_if_finished()
        nav.events.append(ev.MissionCurrent(nav.mission.seq))

    def setpoint(self, armed, now_s):
        nav = self.nav
        if not armed:
            return super().setpoint(armed, now_s)
        sp = nav.mission.setpoint(nav.vehicle, now_s)
        for severity, text in nav.mission.texts:
            nav.events.append(ev.StatusText(severity, text))
        nav.mission.texts.clear()
        nav.events.extend(nav.mission.commands)
        nav.mission.commands.clear()
        for seq in nav.mission.take_reached():
            nav.events.append(ev.ItemReached(seq))
            if not nav.mission.finished:
                nav.events.append(ev.MissionCurrent(nav.mission.seq))
        return sp

    def landing(self):
        return self.nav.mission.landing()

    def taking_off(self):
        return self.nav.mission.taking_off()
