"""A plant that only climbs and sinks, exported by pythonfmu3 as an FMI 3.0 co-simulation FMU: four linear
rotors (commands 0..1, 5 N each) lift a 1 kg body off flat ground. ENU earth and FLU body frames, the
attitude as a quaternion in x-y-z-w order; constant acceleration over a step, so a climb is exact."""

from pythonfmu3 import Float64, Fmi3Causality, Fmi3Slave, Fmi3Variability

G = 9.80665
OUTPUTS = ("east", "north", "up", "v_east", "v_north", "v_up", "q_x", "q_y", "q_z", "q_w", "roll_rate",
           "pitch_rate", "yaw_rate", "f_x", "f_y", "f_z")


class VerticalLift(Fmi3Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.description = "vertical point mass on four rotors, FMI 3.0"
        self.time, self.mass, self.thrust_max = 0.0, 1.0, 5.0
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous))  # FMI 3.0 requires one
        for name in ("mass", "thrust_max"):
            self.register_variable(Float64(name, causality=Fmi3Causality.parameter,
                                           variability=Fmi3Variability.fixed))
        for i in range(1, 5):
            setattr(self, f"u{i}", 0.0)
            self.register_variable(Float64(f"u{i}", causality=Fmi3Causality.input,
                                           variability=Fmi3Variability.continuous))
        for name in OUTPUTS:
            setattr(self, name, 0.0)
            self.register_variable(Float64(name, causality=Fmi3Causality.output,
                                           variability=Fmi3Variability.continuous))
        self.q_w = 1.0
        self.f_z = G  # resting: an FLU accelerometer reads +g

    def do_step(self, current_time, step_size):
        thrust = self.thrust_max * sum(min(max(getattr(self, f"u{i}"), 0.0), 1.0) for i in range(1, 5))
        accel = thrust / self.mass - G
        if self.up <= 0.0 and accel <= 0.0:  # held by the ground
            accel, self.v_up = 0.0, 0.0
        self.up += self.v_up * step_size + 0.5 * accel * step_size**2
        self.v_up += accel * step_size
        if self.up < 0.0:
            self.up, self.v_up, accel = 0.0, 0.0, 0.0
        self.f_z = accel + G
        self.time = current_time + step_size
        return True
