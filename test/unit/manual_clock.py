"""A clock that moves only when a test moves it: clock() reads `now_s`, sleep() adds to it.
Not a test module: the offline tests import it (the bridge's rig has its own, which also runs on)."""


class ManualClock:
    def __init__(self, now_s=100.0):
        self.now_s = now_s

    def __call__(self):
        return self.now_s

    def sleep(self, seconds):
        self.now_s += seconds
