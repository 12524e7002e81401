"""A quadrotor plant written apart from the bench's C model, exported as an FMI 2.0 co-simulation FMU by
pythonfmu: the same vehicle (the bench's default 1 kg quad), its own equations and conventions.

ENU earth frame, FLU body frame, attitude as ZYX Euler angles in degrees (FLU -> ENU), body rates in deg/s,
rotor speeds in rpm, rotor commands as PWM 1000..2000 us, rotors lettered clockwise from the front left
(a front-left CW, b front-right CCW, c rear-right CW, d rear-left CCW, seen from above). Heun's method
(RK2) at a 2 ms internal step. It starts resting on flat ground at height 0, heading `psi0_deg` (ENU: from east
towards north).
"""

import math

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

ROTORS = "abcd"
G = 9.80665


def _rotation(q):
    """Body FLU -> ENU matrix of the unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class EnuQuadrotor(Fmi2Slave):
    author = "hil-bench tests"
    description = "Quadrotor in ENU/FLU, degrees, PWM commands, Heun integration"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.mass_kg, self.jxx, self.jyy, self.jzz = 1.0, 0.011, 0.011, 0.021
        self.arm_m, self.thrust_max_n, self.curve_k, self.lag_s = 0.25, 5.0, 0.5, 0.02
        self.yaw_arm_m, self.speed_max_rad_s = 0.016, 1000.0
        self.drag_x, self.drag_y, self.drag_z = 0.25, 0.25, 0.35
        self.h_s, self.psi0_deg = 0.002, 0.0
        for name in ("mass_kg", "jxx", "jyy", "jzz", "arm_m", "thrust_max_n", "curve_k", "lag_s", "yaw_arm_m",
                     "speed_max_rad_s", "drag_x", "drag_y", "drag_z", "h_s", "psi0_deg"):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed))
        inputs = [f"pwm_{r}" for r in ROTORS] + ["wind_e", "wind_n", "wind_u", "push_e", "push_n", "push_u",
                                                "twist_x", "twist_y", "twist_z", "extra_mass"]
        for name in inputs:
            setattr(self, name, 1000.0 if name.startswith("pwm") else 0.0)
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous))
        self.outputs = (["x_e", "y_n", "z_u", "v_e", "v_n", "v_u", "phi_deg", "theta_deg", "psi_deg", "p_dps",
                         "q_dps", "r_dps", "acc_x", "acc_y", "acc_z", "mass_total"]
                        + [f"thrust_{r}" for r in ROTORS] + [f"rpm_{r}" for r in ROTORS])
        for name in self.outputs:
            setattr(self, name, 0.0)
            self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous))
        self.pos, self.vel, self.omega = np.zeros(3), np.zeros(3), np.zeros(3)
        self.quat, self.thrust = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(4)
        self.grounded = True

    def exit_initialization_mode(self):
        half = math.radians(self.psi0_deg) / 2
        self.quat = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])
        self.thrust = self._commanded()
        self._publish()

    # -- the model --

    def _commanded(self):
        u = np.clip((np.array([getattr(self, f"pwm_{r}") for r in ROTORS]) - 1000.0) / 1000.0, 0.0, 1.0)
        return self.thrust_max_n * ((1 - self.curve_k) * u + self.curve_k * u * u)

    def _placement(self):
        """FLU positions of rotors a, b, c, d and their reaction torque sign about up (CW rotor: +)."""
        s = self.arm_m / math.sqrt(2.0)
        return np.array([[s, s], [s, -s], [-s, -s], [-s, s]]), np.array([1.0, -1.0, 1.0, -1.0])

    def _free_motion(self, quat, vel, omega, thrust):
        """Acceleration ENU, angular acceleration FLU of the body in the air."""
        rot = _rotation(quat)
        air = rot.T @ (vel - np.array([self.wind_e, self.wind_n, self.wind_u]))
        force = np.array([-self.drag_x * air[0], -self.drag_y * air[1], -self.drag_z * air[2] + thrust.sum()])
        mass = self.mass_kg + max(self.extra_mass, 0.0)
        acc = (rot @ force + np.array([self.push_e, self.push_n, self.push_u])) / mass + np.array([0.0, 0.0, -G])
        xy, reaction = self._placement()
        torque = np.array([xy[:, 1] @ thrust, -(xy[:, 0] @ thrust), self.yaw_arm_m * (reaction @ thrust)])
        torque += np.array([self.twist_x, self.twist_y, self.twist_z])
        inertia = np.array([self.jxx, self.jyy, self.jzz])
        return acc, (torque - np.cross(omega, inertia * omega)) / inertia

    def _rates(self, state, grounded):
        _, vel, quat, omega, thrust = state
        d_thrust = (self._commanded() - thrust) / self.lag_s if self.lag_s > 0 else np.zeros(4)
        if grounded:
            return [np.zeros(3), np.zeros(3), np.zeros(4), np.zeros(3), d_thrust]
        acc, alpha = self._free_motion(quat, vel, omega, thrust)
        w, x, y, z = quat
        p, q, r = omega
        d_quat = 0.5 * np.array([-x * p - y * q - z * r, w * p + y * r - z * q, w * q - x * r + z * p,
                                 w * r + x * q - y * p])
        return [vel, acc, d_quat, alpha, d_thrust]

    def _on_ground(self):
        return self.pos[2] <= 1e-9 and self._free_motion(self.quat, self.vel, self.omega, self.thrust)[0][2] <= 0

    def _heun(self, h):
        state = [self.pos, self.vel, self.quat, self.omega, self.thrust]
        self.grounded = self._on_ground()
        k1 = self._rates(state, self.grounded)
        guess = [s + h * k for s, k in zip(state, k1, strict=True)]
        k2 = self._rates(guess, self.grounded)
        self.pos, self.vel, self.quat, self.omega, self.thrust = (
            s + 0.5 * h * (a + b) for s, a, b in zip(state, k1, k2, strict=True))
        self.quat = self.quat / np.linalg.norm(self.quat)
        if self.lag_s <= 0:
            self.thrust = self._commanded()
        if self.pos[2] < 0:  # touched down: stand still on the ground, level, heading kept
            self.pos[2], self.vel, self.omega = 0.0, np.zeros(3), np.zeros(3)
            heading = math.atan2(2 * (self.quat[0] * self.quat[3] + self.quat[1] * self.quat[2]),
                                 1 - 2 * (self.quat[2] ** 2 + self.quat[3] ** 2))
            self.quat = np.array([math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2)])

    def do_step(self, current_time, step_size):
        done = 0.0
        while step_size - done > 1e-12:
            h = min(self.h_s, step_size - done)
            self._heun(h)
            done += h
        self._publish()
        return True

    def _publish(self):
        rot = _rotation(self.quat)
        grounded = self._on_ground()
        acc = np.zeros(3) if grounded else self._free_motion(self.quat, self.vel, self.omega, self.thrust)[0]
        specific = rot.T @ (acc - np.array([0.0, 0.0, -G]))
        euler = (math.atan2(rot[2, 1], rot[2, 2]), math.asin(max(-1.0, min(1.0, -rot[2, 0]))),
                 math.atan2(rot[1, 0], rot[0, 0]))
        values = [*self.pos, *self.vel, *(math.degrees(a) for a in euler), *np.degrees(self.omega), *specific,
                  self.mass_kg + max(self.extra_mass, 0.0), *self.thrust,
                  *(self.speed_max_rad_s * math.sqrt(max(t, 0.0) / self.thrust_max_n) * 60 / (2 * math.pi)
                    for t in self.thrust)]
        for name, value in zip(self.outputs, values, strict=True):
            setattr(self, name, float(value))
