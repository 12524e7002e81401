/*
 * Multirotor plant (PX4's quad X or hexa X, parameter rotor_count) as an FMI 2.0 co-simulation FMU.
 *
 * SI units; NED earth frame, FRD body frame, quaternion w-x-y-z rotating body FRD
 * into NED (as PX4). Value references and defaults come from quadrotor_vars.h,
 * which is generated together with modelDescription.xml from plant_fmu/variables.py.
 *
 * State x: pos_ned[3], vel_ned[3], q[4], omega_frd[3], rotor thrust[MAX_ROTORS] (the unused ones stay 0),
 * battery charge drawn (C).
 * Each doStep integrates with fixed-step RK4 (parameter integration_step), the
 * last sub-step shortened to land exactly on the communication point.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "quadrotor_vars.h"

#define MAX_ROTORS 6
#define MAX_CELLS 14
#define X_CHARGE (13 + MAX_ROTORS)
#define NX (X_CHARGE + 1)
#define X_POS 0
#define X_VEL 3
#define X_Q 6
#define X_W 10
#define X_T 13
#define SETTLE_TAU_S 0.1 /* a vehicle touching down tilted settles onto its legs with this time constant */

typedef struct {
    double r[NVARS];
    double x[NX];
    double time;
    int contact;
    int initialized;
    fmi2CallbackFunctions cb;
    char name[64];
} Model;

#define P(m, name) ((m)->r[VR_##name])

static void log_msg(Model *m, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    if (!m->cb.logger) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* buf is already formatted; hosts such as fmpy read the format argument as the text */
    for (char *c = buf; *c; c++)
        if (*c == '%') *c = ' ';
    m->cb.logger(m->cb.componentEnvironment, m->name, status, category, buf);
}

/* Rotation matrix body FRD -> NED from a unit quaternion (w, x, y, z). */
static void quat_to_dcm(const double *q, double R[3][3]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0][0] = 1 - 2 * (y * y + z * z); R[0][1] = 2 * (x * y - w * z);     R[0][2] = 2 * (x * z + w * y);
    R[1][0] = 2 * (x * y + w * z);     R[1][1] = 1 - 2 * (x * x + z * z); R[1][2] = 2 * (y * z - w * x);
    R[2][0] = 2 * (x * z - w * y);     R[2][1] = 2 * (y * z + w * x);     R[2][2] = 1 - 2 * (x * x + y * y);
}

static double clamp(double u, double lo, double hi) { return u < lo ? lo : (u > hi ? hi : u); }

/* Commanded (steady-state) thrust of rotor i, including its health factor. A reversible
 * rotor takes -1..1 (PX4's range for reversible motors) and pushes both ways. */
static double thrust_command(const Model *m, int i) {
    double u = clamp(m->r[VR_motor_cmd_1 + i], P(m, rotor_reversible) > 0.5 ? -1.0 : 0.0, 1.0);
    double k = P(m, thrust_curve_k);
    double health = m->r[VR_motor_health_1 + i];
    if (health < 0) health = 0;
    return health * P(m, thrust_max) * ((1 - k) * u + k * u * fabs(u));
}

/* Rotor positions (FRD, in units of rotor_scale) and spin (+1 CCW seen from above, PX4's CA_ROTORi_KM > 0),
 * in PX4's motor order. Quad X: PX4 airframe 4001, rotors at (+-1, +-1) arm/sqrt2. Hexa X: PX4 airframe 6001
 * (CA_ROTOR0..5 at azimuths 90, 270, 330, 150, 30, 210 deg from the nose), rotors at the arm length. */
static const double QUAD_X[4] = {+1, -1, +1, -1};
static const double QUAD_Y[4] = {+1, -1, -1, +1};
static const double QUAD_SPIN[4] = {+1, +1, -1, -1};
static const double HEXA_X[6] = {0, 0, 0.8660254037844386, -0.8660254037844386, 0.8660254037844386,
                                 -0.8660254037844386};
static const double HEXA_Y[6] = {+1, -1, -0.5, +0.5, +0.5, -0.5};
static const double HEXA_SPIN[6] = {-1, +1, -1, +1, +1, -1};

static int rotor_count(const Model *m) { return (int)P(m, rotor_count); }
static int is_hexa(const Model *m) { return rotor_count(m) == 6; }
static double rotor_x(const Model *m, int i) { return is_hexa(m) ? HEXA_X[i] : QUAD_X[i]; }
static double rotor_y(const Model *m, int i) { return is_hexa(m) ? HEXA_Y[i] : QUAD_Y[i]; }
static double rotor_spin(const Model *m, int i) { return is_hexa(m) ? HEXA_SPIN[i] : QUAD_SPIN[i]; }
/* The length that rotor_x and rotor_y are in units of. */
static double rotor_scale(const Model *m) { return is_hexa(m) ? P(m, arm_length) : P(m, arm_length) / sqrt(2.0); }

/* Sum of the rotors' thrusts, added left to right. */
static double thrust_sum(const Model *m, const double *thrust) {
    double sum = thrust[0];
    for (int i = 1; i < rotor_count(m); i++) sum += thrust[i];
    return sum;
}

/* Body torque from rotor thrusts: r x (0, 0, -T) plus drag torque, CCW rotors yaw right. */
static void rotor_torque(const Model *m, const double *thrust, double tau[3]) {
    double a = rotor_scale(m);
    tau[0] = tau[1] = tau[2] = 0;
    for (int i = 0; i < rotor_count(m); i++) {
        tau[0] += -a * rotor_y(m, i) * thrust[i];
        tau[1] += a * rotor_x(m, i) * thrust[i];
        tau[2] += rotor_spin(m, i) * P(m, yaw_moment_coeff) * thrust[i];
    }
}

static double total_mass(const Model *m) {
    double payload = m->r[VR_payload_mass];
    return P(m, mass) + (payload > 0 ? payload : 0);
}

/* Any rotor-aerodynamic or parasitic term on? Off, the model is exactly the one without them. */
static int aero_on(const Model *m) {
    return P(m, rotor_drag_coeff) != 0 || P(m, induced_inflow_coeff) != 0 || P(m, translational_lift_coeff) != 0 ||
           P(m, flapping_coeff) != 0 || P(m, parasitic_drag_area_x) != 0 || P(m, parasitic_drag_area_y) != 0 ||
           P(m, parasitic_drag_area_z) != 0;
}

/* Rotor speed from thrust through T = k_eta w^2 (signed for a reversible rotor). */
static double rotor_speed(const Model *m, double thrust) {
    double w = P(m, rotor_speed_max) * sqrt(fabs(thrust) / P(m, thrust_max)); /* sqrt(|T| / k_eta) */
    return thrust < 0 ? -w : w;
}

/* Air velocity of the body in FRD: R^T (v - wind). */
static void body_air_velocity(const Model *m, const double *x, double R[3][3], double v_air_b[3]) {
    double v_air[3] = {x[X_VEL + 0] - m->r[VR_wind_n], x[X_VEL + 1] - m->r[VR_wind_e], x[X_VEL + 2] - m->r[VR_wind_d]};
    for (int i = 0; i < 3; i++)
        v_air_b[i] = R[0][i] * v_air[0] + R[1][i] * v_air[1] + R[2][i] * v_air[2];
}

/* The aerodynamic wrench in FRD beyond the linear body drag: per rotor, at its hub's air velocity
 * v_h = v_air_b + w x r_i split into in-plane (x, y) and axial (z) parts, with rotor speed W:
 *   rotor drag       F = -k_d W (v_hx, v_hy, 0)
 *   induced inflow   thrust - k_z W v_climb, v_climb = -v_hz (the rotor climbing through the air)
 *   transl. lift     thrust + k_h (v_hx^2 + v_hy^2)
 *   blade flapping   M = -k_flap W (v_in x z_body)  (air from ahead pitches the nose up)
 * and the body's parasitic drag -1/2 rho CdA |v_air| v_air per axis. `thrust_eff` gets each rotor's
 * thrust with the inflow and lift changes; force and torque exclude the thrust itself. */
static void aero_wrench(const Model *m, const double *x, const double v_air_b[3], double thrust_eff[MAX_ROTORS],
                        double f_b[3], double tau_b[3]) {
    const double *w = x + X_W, *thrust = x + X_T;
    double a = rotor_scale(m);
    double k_d = P(m, rotor_drag_coeff), k_z = P(m, induced_inflow_coeff);
    double k_h = P(m, translational_lift_coeff), k_flap = P(m, flapping_coeff);
    double half_rho = 0.5 * P(m, air_density);
    double speed = sqrt(v_air_b[0] * v_air_b[0] + v_air_b[1] * v_air_b[1] + v_air_b[2] * v_air_b[2]);
    f_b[0] = -half_rho * P(m, parasitic_drag_area_x) * speed * v_air_b[0];
    f_b[1] = -half_rho * P(m, parasitic_drag_area_y) * speed * v_air_b[1];
    f_b[2] = -half_rho * P(m, parasitic_drag_area_z) * speed * v_air_b[2];
    tau_b[0] = tau_b[1] = tau_b[2] = 0;
    for (int i = 0; i < rotor_count(m); i++) {
        double rx = a * rotor_x(m, i), ry = a * rotor_y(m, i);
        /* hub velocity: v + w x r with r = (rx, ry, 0) */
        double vx = v_air_b[0] - w[2] * ry, vy = v_air_b[1] + w[2] * rx, vz = v_air_b[2] + w[0] * ry - w[1] * rx;
        double spin = fabs(rotor_speed(m, thrust[i]));
        double fx = -k_d * spin * vx, fy = -k_d * spin * vy;
        thrust_eff[i] = thrust[i] - k_z * spin * (-vz) + k_h * (vx * vx + vy * vy);
        f_b[0] += fx;
        f_b[1] += fy;
        tau_b[2] += rx * fy - ry * fx; /* r x F of the in-plane drag at the hub */
        /* v_in x z_body = (vy, -vx, 0) */
        tau_b[0] += -k_flap * spin * vy;
        tau_b[1] += k_flap * spin * vx;
    }
}

/* Body-frame force (thrust, drag, aerodynamics) and, if `tau` is given, torque, for state x. */
static void body_wrench(const Model *m, const double *x, double R[3][3], double f_b[3], double *tau) {
    double v_air_b[3];
    const double *thrust = x + X_T;
    body_air_velocity(m, x, R, v_air_b);
    f_b[0] = -P(m, drag_coeff_x) * v_air_b[0];
    f_b[1] = -P(m, drag_coeff_y) * v_air_b[1];
    f_b[2] = -P(m, drag_coeff_z) * v_air_b[2];
    if (!aero_on(m)) {
        f_b[2] -= thrust_sum(m, thrust);
        if (tau) rotor_torque(m, thrust, tau);
        return;
    }
    double thrust_eff[MAX_ROTORS], f_aero[3], tau_aero[3];
    aero_wrench(m, x, v_air_b, thrust_eff, f_aero, tau_aero);
    for (int i = 0; i < 3; i++) f_b[i] += f_aero[i];
    f_b[2] -= thrust_sum(m, thrust_eff);
    if (tau) {
        double a = rotor_scale(m);
        rotor_torque(m, thrust, tau); /* yaw drag torque of the rotors, from their thrust curve */
        tau[0] = tau[1] = 0;
        for (int i = 0; i < rotor_count(m); i++) { /* roll and pitch from each rotor's effective thrust */
            tau[0] += -a * rotor_y(m, i) * thrust_eff[i];
            tau[1] += a * rotor_x(m, i) * thrust_eff[i];
        }
        for (int i = 0; i < 3; i++) tau[i] += tau_aero[i];
    }
}

/* ---- Battery: N LiPo cells in series with a series resistance each, discharged by the rotors' shaft power
 * over an efficiency and a base current. Nothing of it acts back on the flight. ---- */

/* Open-circuit voltage of one lithium-ion polymer cell against state of charge: M. Chen and G. A.
 * Rincon-Mora, "Accurate electrical battery model capable of predicting runtime and I-V performance",
 * IEEE Trans. Energy Conversion 21(2), 2006, eq. for V_oc(SOC) (4.10 V full, 2.65 V empty). */
static double cell_ocv(double soc) {
    double s = clamp(soc, 0.0, 1.0);
    return -1.031 * exp(-35.0 * s) + 3.685 + 0.2156 * s - 0.1178 * s * s + 0.3201 * s * s * s;
}

static int cell_count(const Model *m) { return (int)P(m, battery_cells); }

/* The failing cell, 1..N, or 0. */
static int fault_cell(const Model *m) {
    int k = (int)lround(m->r[VR_battery_fault_cell]);
    return k >= 1 && k <= cell_count(m) ? k : 0;
}

static double state_of_charge(const Model *m, double charge_c) {
    return P(m, battery_initial_soc) - charge_c / (3600.0 * P(m, battery_capacity));
}

static double pack_ocv(const Model *m, double soc) {
    return cell_count(m) * cell_ocv(soc) - (fault_cell(m) ? m->r[VR_battery_fault_voltage] : 0.0);
}

static double pack_resistance(const Model *m) {
    return cell_count(m) * P(m, battery_cell_resistance) + (fault_cell(m) ? m->r[VR_battery_fault_resistance] : 0.0);
}

/* Shaft power of the rotors: drag torque k_m |T| times speed w (rotor_speed). */
static double rotor_power(const Model *m, const double *thrust) {
    double power = 0;
    for (int i = 0; i < rotor_count(m); i++)
        power += P(m, yaw_moment_coeff) * fabs(thrust[i]) * fabs(rotor_speed(m, thrust[i]));
    return power;
}

/* Pack current I drawing the rotors' electrical power P = P_shaft / efficiency at the terminal voltage
 * V = V_oc - R I besides the base current I_b: (I - I_b)(V_oc - R I) = P, the smaller root; past the
 * pack's maximum power the current stays at that point. */
static double battery_current(const Model *m, const double *x) {
    double v_oc = pack_ocv(m, state_of_charge(m, x[X_CHARGE])), r = pack_resistance(m);
    double i_b = P(m, battery_base_current), p = rotor_power(m, x + X_T) / P(m, battery_efficiency);
    if (r <= 0) return i_b + (v_oc > 0 ? p / v_oc : 0);
    double b = v_oc + r * i_b, disc = b * b - 4 * r * (v_oc * i_b + p);
    return (b - sqrt(disc > 0 ? disc : 0)) / (2 * r);
}

static void battery_outputs(Model *m, const double *x) {
    double current = battery_current(m, x), soc = state_of_charge(m, x[X_CHARGE]);
    double healthy = cell_ocv(soc) - current * P(m, battery_cell_resistance);
    int fault = fault_cell(m);
    m->r[VR_battery_current] = current;
    m->r[VR_battery_voltage] = pack_ocv(m, soc) - current * pack_resistance(m);
    m->r[VR_battery_consumed] = x[X_CHARGE] / 3600.0;
    m->r[VR_battery_remaining] = soc > 0 ? soc : 0;
    for (int k = 1; k <= MAX_CELLS; k++) {
        double v = 0;
        if (k <= cell_count(m)) {
            v = healthy;
            if (k == fault) v -= m->r[VR_battery_fault_voltage] + current * m->r[VR_battery_fault_resistance];
        }
        m->r[VR_cell_voltage_1 + k - 1] = v;
    }
}

/* Translational acceleration in NED from the body-frame force f_b (plus disturbance and gravity). */
static void accel_from_force(const Model *m, double R[3][3], const double f_b[3], double acc[3]) {
    double mass = total_mass(m);
    for (int i = 0; i < 3; i++) {
        double f_ned = R[i][0] * f_b[0] + R[i][1] * f_b[1] + R[i][2] * f_b[2];
        acc[i] = f_ned / mass;
    }
    acc[0] += m->r[VR_f_dist_n] / mass;
    acc[1] += m->r[VR_f_dist_e] / mass;
    acc[2] += m->r[VR_f_dist_d] / mass + P(m, g);
}

/* Translational acceleration in NED of a free (airborne) body in state x. */
static void free_accel(const Model *m, const double *x, double acc[3]) {
    double R[3][3], f_b[3];
    quat_to_dcm(x + X_Q, R);
    body_wrench(m, x, R, f_b, NULL);
    accel_from_force(m, R, f_b, acc);
}

static double ground_d(const Model *m) { return -P(m, ground_height); }

/* Body rates that level the attitude on the ground, keeping the heading: roll and pitch decay with SETTLE_TAU_S
   (Euler rates -roll/tau, -pitch/tau, yaw rate 0, turned into body rates), so a vehicle that touches down tilted
   rocks onto its legs at rates its gyro sees instead of being levelled in one step. */
static void settle_rates(const double *q, double w[3]) {
    double roll = atan2(2 * (q[0] * q[1] + q[2] * q[3]), 1 - 2 * (q[1] * q[1] + q[2] * q[2]));
    double s = 2 * (q[0] * q[2] - q[3] * q[1]);
    double pitch = asin(s > 1 ? 1 : (s < -1 ? -1 : s));
    double roll_dot = -roll / SETTLE_TAU_S, pitch_dot = -pitch / SETTLE_TAU_S;
    w[0] = roll_dot;
    w[1] = cos(roll) * pitch_dot;
    w[2] = -sin(roll) * pitch_dot;
}

static void quat_rate(const double *q, const double *w, double *q_dot) {
    /* q_dot = 0.5 q (x) (0, w) */
    q_dot[0] = 0.5 * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2]);
    q_dot[1] = 0.5 * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1]);
    q_dot[2] = 0.5 * (q[0] * w[1] - q[1] * w[2] + q[3] * w[0]);
    q_dot[3] = 0.5 * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0]);
}

/* dx/dt. While in ground contact the body is held in place and only settles level; the rotors evolve. */
static void derivatives(const Model *m, const double *x, int contact, double *dx) {
    const double *q = x + X_Q, *w = x + X_W, *thrust = x + X_T;
    double tau[3];
    double Ixx = P(m, Ixx), Iyy = P(m, Iyy), Izz = P(m, Izz), tau_m = P(m, motor_tau);

    for (int i = 0; i < MAX_ROTORS; i++)
        dx[X_T + i] = tau_m > 0 && i < rotor_count(m) ? (thrust_command(m, i) - thrust[i]) / tau_m : 0;
    dx[X_CHARGE] = battery_current(m, x);
    if (contact) {
        double w_settle[3];
        memset(dx, 0, sizeof(double) * X_T);
        settle_rates(q, w_settle);
        quat_rate(q, w_settle, dx + X_Q);
        return;
    }
    double R[3][3], f_b[3];
    quat_to_dcm(q, R);
    body_wrench(m, x, R, f_b, tau); /* one evaluation of the wrench serves both equations */
    for (int i = 0; i < 3; i++) dx[X_POS + i] = x[X_VEL + i];
    accel_from_force(m, R, f_b, dx + X_VEL);

    quat_rate(q, w, dx + X_Q);

    /* I w_dot = tau - w x I w */
    tau[0] += m->r[VR_tau_dist_x];
    tau[1] += m->r[VR_tau_dist_y];
    tau[2] += m->r[VR_tau_dist_z];
    dx[X_W + 0] = (tau[0] - (Izz - Iyy) * w[1] * w[2]) / Ixx;
    dx[X_W + 1] = (tau[1] - (Ixx - Izz) * w[2] * w[0]) / Iyy;
    dx[X_W + 2] = (tau[2] - (Iyy - Ixx) * w[0] * w[1]) / Izz;
}

static void normalize_quat(double *q) {
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++) q[i] /= n;
}

/* Contact holds while the body touches the ground and the free forces push it down. */
static int in_contact(const Model *m, const double *x) {
    double acc[3];
    if (x[X_POS + 2] < ground_d(m) - 1e-9) return 0;
    free_accel(m, x, acc);
    return acc[2] >= 0;
}

static void rk4_step(Model *m, double h) {
    double k1[NX], k2[NX], k3[NX], k4[NX], xt[NX];
    int contact;
    if (P(m, motor_tau) <= 0) /* ideal rotors follow the command at once */
        for (int i = 0; i < rotor_count(m); i++) m->x[X_T + i] = thrust_command(m, i);
    contact = in_contact(m, m->x);
    m->contact = contact;
    derivatives(m, m->x, contact, k1);
    for (int i = 0; i < NX; i++) xt[i] = m->x[i] + 0.5 * h * k1[i];
    derivatives(m, xt, contact, k2);
    for (int i = 0; i < NX; i++) xt[i] = m->x[i] + 0.5 * h * k2[i];
    derivatives(m, xt, contact, k3);
    for (int i = 0; i < NX; i++) xt[i] = m->x[i] + h * k3[i];
    derivatives(m, xt, contact, k4);
    for (int i = 0; i < NX; i++) m->x[i] += h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    if (P(m, motor_tau) <= 0)
        for (int i = 0; i < rotor_count(m); i++) m->x[X_T + i] = thrust_command(m, i);
    normalize_quat(m->x + X_Q);
    if (m->x[X_POS + 2] > ground_d(m)) { /* touched down during this step: it stops and starts to settle */
        m->x[X_POS + 2] = ground_d(m);
        memset(m->x + X_VEL, 0, 3 * sizeof(double));
        m->contact = 1;
    }
    if (m->contact) /* on the ground the body turns only as it settles, and the gyro reads that turn */
        settle_rates(m->x + X_Q, m->x + X_W);
}

/* Copy the state and derived quantities into the output variables. */
static void update_outputs(Model *m) {
    double R[3][3], acc[3], tau[3];
    const double *x = m->x, *q = x + X_Q;
    double g = P(m, g), thrust_total = 0;
    int contact = in_contact(m, x);

    for (int i = 0; i < 3; i++) {
        m->r[VR_pos_n + i] = x[X_POS + i];
        m->r[VR_vel_n + i] = x[X_VEL + i];
        m->r[VR_rate_x + i] = x[X_W + i];
    }
    for (int i = 0; i < 4; i++) m->r[VR_q_w + i] = q[i];
    for (int i = 0; i < MAX_ROTORS; i++) {
        m->r[VR_thrust_1 + i] = x[X_T + i];
        m->r[VR_rotor_speed_1 + i] = rotor_speed(m, x[X_T + i]);
    }
    for (int i = 0; i < rotor_count(m); i++) thrust_total += x[X_T + i];
    m->r[VR_thrust_total] = thrust_total;
    if (contact) acc[0] = acc[1] = acc[2] = 0;
    else free_accel(m, x, acc);
    m->r[VR_acc_n] = acc[0];
    m->r[VR_acc_e] = acc[1];
    m->r[VR_acc_d] = acc[2];
    quat_to_dcm(q, R);
    /* specific force = R^T (a - g e3), what an accelerometer reads */
    for (int i = 0; i < 3; i++)
        m->r[VR_specific_force_x + i] = R[0][i] * acc[0] + R[1][i] * acc[1] + R[2][i] * (acc[2] - g);
    m->r[VR_roll] = atan2(2 * (q[0] * q[1] + q[2] * q[3]), 1 - 2 * (q[1] * q[1] + q[2] * q[2]));
    {
        double s = 2 * (q[0] * q[2] - q[3] * q[1]);
        m->r[VR_pitch] = asin(s > 1 ? 1 : (s < -1 ? -1 : s));
    }
    m->r[VR_yaw] = atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
    rotor_torque(m, x + X_T, tau);
    m->r[VR_torque_x] = tau[0];
    m->r[VR_torque_y] = tau[1];
    m->r[VR_torque_z] = tau[2];
    m->r[VR_total_mass] = total_mass(m);
    m->r[VR_on_ground] = contact ? 1.0 : 0.0;
    m->contact = contact;
    battery_outputs(m, x);
}

static void initialize_state(Model *m) {
    double yaw = P(m, init_yaw);
    memset(m->x, 0, sizeof m->x);
    m->x[X_POS + 0] = P(m, init_pos_n);
    m->x[X_POS + 1] = P(m, init_pos_e);
    m->x[X_POS + 2] = P(m, init_pos_d) > ground_d(m) ? ground_d(m) : P(m, init_pos_d);
    m->x[X_Q + 0] = cos(yaw / 2);
    m->x[X_Q + 3] = sin(yaw / 2);
    for (int i = 0; i < rotor_count(m); i++) m->x[X_T + i] = thrust_command(m, i);
    update_outputs(m);
}

static void set_defaults(Model *m) {
    memcpy(m->r, VAR_START, sizeof m->r);
    m->time = 0;
    initialize_state(m);
}

static int parameters_valid(Model *m) {
    if (!(P(m, mass) > 0 && P(m, Ixx) > 0 && P(m, Iyy) > 0 && P(m, Izz) > 0)) {
        log_msg(m, fmi2Error, "logStatusError", "mass and inertias must be positive");
        return 0;
    }
    if (!(P(m, integration_step) > 0)) {
        log_msg(m, fmi2Error, "logStatusError", "integration_step must be positive");
        return 0;
    }
    if (!(P(m, arm_length) > 0 && P(m, thrust_max) > 0 && P(m, motor_tau) >= 0)) {
        log_msg(m, fmi2Error, "logStatusError", "arm_length, thrust_max must be > 0 and motor_tau >= 0");
        return 0;
    }
    if (!(rotor_count(m) == 4 || rotor_count(m) == 6)) {
        log_msg(m, fmi2Error, "logStatusError", "rotor_count must be 4 (quad X) or 6 (hexa X)");
        return 0;
    }
    if (!(cell_count(m) >= 1 && cell_count(m) <= MAX_CELLS && P(m, battery_capacity) > 0 &&
          P(m, battery_initial_soc) >= 0 && P(m, battery_initial_soc) <= 1 && P(m, battery_cell_resistance) >= 0 &&
          P(m, battery_efficiency) > 0 && P(m, battery_efficiency) <= 1 && P(m, battery_base_current) >= 0)) {
        log_msg(m, fmi2Error, "logStatusError", "battery: cells 1..14, capacity > 0, initial soc 0..1, "
                "resistance >= 0, efficiency in (0, 1], base current >= 0");
        return 0;
    }
    if (!(P(m, rotor_speed_max) > 0 && P(m, air_density) >= 0)) {
        log_msg(m, fmi2Error, "logStatusError", "rotor_speed_max must be > 0 and air_density >= 0");
        return 0;
    }
    return 1;
}

/* ---------------- FMI 2.0 API ---------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                              fmi2String resourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Model *m;
    (void)resourceLocation; (void)visible; (void)loggingOn;
    if (fmuType != fmi2CoSimulation || !guid || strcmp(guid, MODEL_GUID) != 0) return NULL;
    m = (Model *)calloc(1, sizeof(Model));
    if (!m) return NULL;
    if (functions) m->cb = *functions;
    snprintf(m->name, sizeof m->name, "%s", instanceName ? instanceName : "Quadrotor");
    set_defaults(m);
    return m;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c; (void)on; (void)n; (void)cat;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol,
                               fmi2Real startTime, fmi2Boolean stopDefined, fmi2Real stopTime) {
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stopTime;
    ((Model *)c)->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Model *m = (Model *)c;
    if (!parameters_valid(m)) return fmi2Error;
    initialize_state(m);
    m->initialized = 1;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    Model *m = (Model *)c;
    set_defaults(m);
    m->initialized = 0;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS) return fmi2Error;
        value[i] = m->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS || VAR_CAUSALITY[vr[i]] == CAUSALITY_OUTPUT || VAR_TYPE[vr[i]] != TYPE_REAL)
            return fmi2Error;
        if (VAR_CAUSALITY[vr[i]] == CAUSALITY_PARAMETER && m->initialized) {
            log_msg(m, fmi2Error, "logStatusError", "parameter %u is fixed after initialization", vr[i]);
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            log_msg(m, fmi2Error, "logStatusError", "non-finite value for variable %u", vr[i]);
            return fmi2Error;
        }
        m->r[vr[i]] = value[i];
    }
    if (!m->initialized) initialize_state(m);
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[]) {
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS || VAR_TYPE[vr[i]] != TYPE_BOOLEAN) return fmi2Error;
        value[i] = m->r[vr[i]] != 0.0;
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]) {
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS || VAR_TYPE[vr[i]] != TYPE_INTEGER) return fmi2Error;
        value[i] = (fmi2Integer)m->r[vr[i]];
    }
    return fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String value[]) {
    (void)c; (void)vr; (void)value;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[]) {
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS || VAR_TYPE[vr[i]] != TYPE_INTEGER || VAR_CAUSALITY[vr[i]] != CAUSALITY_PARAMETER)
            return fmi2Error;
        if (m->initialized) {
            log_msg(m, fmi2Error, "logStatusError", "parameter %u is fixed after initialization", vr[i]);
            return fmi2Error;
        }
        m->r[vr[i]] = value[i];
    }
    if (!m->initialized) initialize_state(m);
    return fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean value[]) {
    (void)c; (void)vr; (void)value;
    return n == 0 ? fmi2OK : fmi2Error;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String value[]) {
    (void)c; (void)vr; (void)value;
    return n == 0 ? fmi2OK : fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Model *m = (Model *)c;
    double h_int = P(m, integration_step), done = 0;
    (void)noSetPrior;
    if (h <= 0) return h == 0 ? fmi2OK : fmi2Error;
    while (h - done > 1e-12) {
        double step = h - done < h_int * (1 + 1e-9) ? h - done : h_int;
        rk4_step(m, step);
        done += step;
    }
    for (int i = 0; i < NX; i++) {
        if (!isfinite(m->x[i])) {
            log_msg(m, fmi2Error, "logStatusError", "state diverged (non-finite) at t = %g s", t + h);
            return fmi2Error;
        }
    }
    m->time = t + h;
    update_outputs(m);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)c; (void)s; *value = fmi2OK; return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Model *m = (Model *)c;
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = m->time;
    return fmi2OK;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)c; (void)s; (void)value; return fmi2Discard;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)c; (void)s; (void)value; return fmi2Discard;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)c; (void)s; (void)value; return fmi2Discard;
}

/* Optional capabilities this FMU declares as unsupported in modelDescription.xml. */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)c; (void)s; (void)n; return fmi2Error;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)c; (void)s; (void)b; (void)n; return fmi2Error;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    (void)c; (void)b; (void)n; (void)s; return fmi2Error;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[],
                                        fmi2Real dz[]) {
    (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz; return fmi2Error;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)c; (void)vr; (void)n; (void)order; (void)value; return fmi2Error;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)c; (void)vr; (void)n; (void)order; (void)value; return fmi2Error;
}
