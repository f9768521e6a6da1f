/* jointrig: the joint law, bearing drag and drive as a native MuJoCo passive callback.
 *
 * The same arithmetic, in the same order, as the Python reference (jointrig/vocab/law.py
 * JointLaw.torque scalar path, jointrig/vocab/plant.py PeriodicDrive.evaluator and
 * rig/simulate.py make_callback), so both give the same numbers to the last bit: a test
 * compares whole trajectories. Parameters come from one struct the Python side fills
 * (rig/native_callback.py). Sliders (Jenkins and Iwan elements) are committed after every
 * accepted step: by jointrig_run, which steps the simulation here (mj_step passed in by its
 * address), or by the Python caller.
 */
#include <math.h>
#include <mujoco/mujoco.h>

#define JR_MAX_TERMS 64
#define JR_MAX_KNOTS 512
#define JR_MAX_HARM 256
#define JR_MAX_SLIDERS 2048

enum { JR_VISCOUS = 0, JR_POWER = 1, JR_MONOMIAL = 2, JR_ANGLE_HAT = 3, JR_RATE_HAT = 4,
       JR_COULOMB = 5, JR_QUADRATIC = 6, JR_JENKINS = 7, JR_IWAN = 8, JR_STRIBECK = 9,
       JR_TANH = 10, JR_COGGING = 11, JR_CONTACT_VISCOUS = 12 };

typedef struct {
  int n_terms;
  int kind[JR_MAX_TERMS];
  int ipar1[JR_MAX_TERMS];   /* power / angle power / hat index / first slider */
  int ipar2[JR_MAX_TERMS];   /* rate power / knot offset */
  int ipar3[JR_MAX_TERMS];   /* number of knots / number of sliders (Iwan) */
  double value[JR_MAX_TERMS];
  double dpar[JR_MAX_TERMS]; /* gap (power, contact damping) or slip angle (Jenkins) */
  double knots[JR_MAX_KNOTS];
  int n_sliders;
  double slider[JR_MAX_SLIDERS];      /* slider positions (rad) */
  double slider_slip[JR_MAX_SLIDERS]; /* each slider's slip angle (rad) */
  double slider_k[JR_MAX_SLIDERS];    /* each Iwan element's stiffness per unit macroslip torque */
  int q1, q2, v1, v2, act;
  double b1, b2, delay, omega;
  int single;                /* 1: drive is a * cos(omega * (t - delay)) */
  double single_a;
  int n_coeffs;              /* Horner coefficients 0..n_coeffs-1 */
  double c_re[JR_MAX_HARM], c_im[JR_MAX_HARM];
  int error;
  int cache_valid;           /* the drive at the last time asked (RK4 asks t + h/2 twice) */
  double cache_t, cache_u;
  void* next;                /* a chain: the next block (another joint, or a drive), or 0 */
  /* A one-degree-of-freedom oscillator (rig/oscillator.py): the law between q1 and the ground
   * (q2, v2 < 0) and a sampled input u(t - delay) added to the passive force, both at once as
   * the Python callback does: qfrc_passive[v1] += u - tau. The input is linear between the
   * points of a grid of input_rate points per second (identify.signals.BandlimitedInput). */
  int input_n;               /* points of the input grid (0: no sampled input) */
  const double* input;
  double input_rate;
} jointrig_params;

/* One parameter block per simulation, found by its mjData: simulations in several threads
 * (each with its own mjData) share the one installed callback. The Python side serialises
 * register/unregister; a block is published before its mjData and withdrawn after. */
#define JR_MAX_SIMS 256
static const mjData* volatile JR_D[JR_MAX_SIMS];
static jointrig_params* volatile JR_P[JR_MAX_SIMS];
static volatile int JR_HIGH = 0;  /* slots in use are below this mark: lookups scan only them */

int jointrig_register(const mjData* d, jointrig_params* p) {
  for (int i = 0; i < JR_MAX_SIMS; i++)
    if (JR_D[i] == 0) {
      JR_P[i] = p;
      __sync_synchronize();
      JR_D[i] = d;
      if (JR_HIGH < i + 1) JR_HIGH = i + 1;
      return i;
    }
  return -1;
}

void jointrig_unregister(const mjData* d) {
  for (int i = 0; i < JR_MAX_SIMS; i++)
    if (JR_D[i] == d) { JR_D[i] = 0; __sync_synchronize(); JR_P[i] = 0; }
  int high = JR_HIGH;
  while (high > 0 && JR_D[high - 1] == 0) high--;
  JR_HIGH = high;
}

static jointrig_params* lookup(const mjData* d) {
  int high = JR_HIGH;
  for (int i = 0; i < high; i++)
    if (JR_D[i] == d) return JR_P[i];
  return 0;
}

static double hat(double x, const double* k, int n, int i) {
  int j = 0;
  while (j < n - 2 && x >= k[j + 1]) j++;
  double s = (x - k[j]) / (k[j + 1] - k[j]);
  if (i == j) return 1.0 - s;
  if (i == j + 1) return s;
  return 0.0;
}

/* x^p for an integer p >= 0 by repeated multiplication, left to right: vocab.law.ipow. */
static double ipow(double x, int p) {
  double out = p == 0 ? 1.0 : x;
  for (int i = 1; i < p; i++) out = out * x;
  return out;
}

static double term(jointrig_params* P, int t, double phi, double rate) {
  switch (P->kind[t]) {
    case JR_VISCOUS: return rate;
    case JR_POWER: {
      double g = P->dpar[t];
      if (g > 0) {
        if (phi > g) phi = phi - g;
        else if (phi < -g) phi = phi + g;
        else phi = 0.0;
      }
      return ipow(phi, P->ipar1[t]);
    }
    case JR_MONOMIAL: return ipow(phi, P->ipar1[t]) * ipow(rate, P->ipar2[t]);
    case JR_ANGLE_HAT: return hat(phi, P->knots + P->ipar2[t], P->ipar3[t], P->ipar1[t]);
    case JR_RATE_HAT: return hat(rate, P->knots + P->ipar2[t], P->ipar3[t], P->ipar1[t]);
    case JR_COULOMB: return (double)((rate > 0.0) - (rate < 0.0)) + 0.0;
    case JR_QUADRATIC: return rate * fabs(rate);
    case JR_STRIBECK: {
      double r = rate / P->dpar[t];
      return (double)((rate > 0.0) - (rate < 0.0)) * exp(-(r * r));
    }
    case JR_TANH: return tanh(rate / P->dpar[t]);
    case JR_COGGING: return P->ipar1[t] ? cos(P->dpar[t] * phi) : sin(P->dpar[t] * phi);
    case JR_CONTACT_VISCOUS: return fabs(phi) > P->dpar[t] ? rate : 0.0;
    default: P->error = 1; return 0.0;
  }
}

static double play(double phi, double z, double s) {
  double lo = phi - s, hi = phi + s;
  double m = z > lo ? z : lo;   /* max(z, phi - s) */
  return m < hi ? m : hi;       /* min(., phi + s) */
}

/* The sampled input at time t: BandlimitedInput.__call__'s float path, operation for operation. */
static double sampled_input(const jointrig_params* P, double t) {
  double pos = t * P->input_rate;
  if (pos <= 0.0) return pos < 0.0 ? 0.0 : P->input[0];
  if (pos >= (double)(P->input_n - 1)) return P->input[P->input_n - 1];
  int i = (int)pos;  /* < input_n - 1 here (the check above, before the cast) */
  double f = pos - i;
  return P->input[i] + f * (P->input[i + 1] - P->input[i]);
}

/* One block: its joint's law between q1 and q2 (none if it has no terms), its bearings, and
 * its drive (none if act < 0). A two-flywheel rig has one block; a chain one per joint and one
 * per drive (rig/native_callback.py NativeChain), applied in the order of rig/chain.py's
 * Python callback, so that every generalised force is summed in the same order. */
static void block(jointrig_params* P, mjData* d) {
  if (P->n_terms > 0 || P->input_n > 0) {
    double phi = P->q2 < 0 ? d->qpos[P->q1] : d->qpos[P->q1] - d->qpos[P->q2];
    double rate = P->v2 < 0 ? d->qvel[P->v1] : d->qvel[P->v1] - d->qvel[P->v2];
    double tau = 0.0;
    for (int t = 0; t < P->n_terms; t++) {
      if (P->kind[t] == JR_JENKINS || P->kind[t] == JR_IWAN) continue;
      tau = tau + P->value[t] * term(P, t, phi, rate);
    }
    for (int t = 0; t < P->n_terms; t++) {
      if (P->kind[t] == JR_JENKINS) {
        double s = P->dpar[t];
        tau += P->value[t] * ((phi - play(phi, P->slider[P->ipar1[t]], s)) / s);
      } else if (P->kind[t] == JR_IWAN) {
        double u = 0.0;
        for (int j = P->ipar1[t]; j < P->ipar1[t] + P->ipar3[t]; j++)
          u = u + P->slider_k[j] * (phi - play(phi, P->slider[j], P->slider_slip[j]));
        tau += P->value[t] * u;
      }
    }
    if (P->input_n > 0) {
      d->qfrc_passive[P->v1] += sampled_input(P, d->time - P->delay) - tau;
      return;
    }
    d->qfrc_passive[P->v1] -= tau;
    if (P->v2 >= 0) d->qfrc_passive[P->v2] += tau;
  }
  if (P->b1 != 0.0) d->qfrc_passive[P->v1] -= P->b1 * d->qvel[P->v1];
  if (P->b2 != 0.0) d->qfrc_passive[P->v2] -= P->b2 * d->qvel[P->v2];
  if (P->act < 0) return;
  double t = d->time - P->delay;
  if (P->cache_valid && t == P->cache_t) {
    d->ctrl[P->act] = P->cache_u;
    return;
  }
  double u;
  if (P->single) {
    u = P->single_a * cos(P->omega * t);
  } else {
    double x = P->omega * t;
    double e_re = cos(x), e_im = sin(x);
    double a_re = 0.0, a_im = 0.0;
    for (int n = P->n_coeffs - 1; n >= 0; n--) {
      double r = a_re * e_re - a_im * e_im;
      double i = a_re * e_im + a_im * e_re;
      a_re = r + P->c_re[n];
      a_im = i + P->c_im[n];
    }
    u = a_re;
  }
  P->cache_t = t;
  P->cache_u = u;
  P->cache_valid = 1;
  d->ctrl[P->act] = u;
}

void jointrig_passive(const mjModel* m, mjData* d) {
  for (jointrig_params* P = lookup(d); P; P = (jointrig_params*)P->next) block(P, d);
}

/* Move every slider to the accepted relative angle (vocab.law: Jenkins/Iwan.commit). */
static void commit(jointrig_params* P, const mjData* d) {
  for (; P; P = (jointrig_params*)P->next) {
    if (P->n_sliders == 0) continue;
    double phi = P->q2 < 0 ? d->qpos[P->q1] : d->qpos[P->q1] - d->qpos[P->q2];
    for (int j = 0; j < P->n_sliders; j++) P->slider[j] = play(phi, P->slider[j], P->slider_slip[j]);
  }
}

typedef void (*jr_step_fn)(const mjModel*, mjData*);

/* n samples of k steps each, committing the sliders after every step (as the Python
 * stepping loop of rig/simulate.py does): row i of buf holds sensordata[idx] after the
 * first step of sample i (the sensors of the state before it), tbuf[i] the time before it.
 * Returns -1 if d has no parameter block, else the block's error flag. */
int jointrig_run(void* step, const mjModel* m, mjData* d, int n, int k, const int* idx, int nidx,
                 double* buf, double* tbuf) {
  jointrig_params* P = lookup(d);
  if (!P) return -1;
  jr_step_fn mj_step = (jr_step_fn)step;
  for (int i = 0; i < n; i++) {
    tbuf[i] = d->time;
    mj_step(m, d);
    for (int c = 0; c < nidx; c++) buf[i * nidx + c] = d->sensordata[idx[c]];
    commit(P, d);
    for (int j = 1; j < k; j++) {
      mj_step(m, d);
      commit(P, d);
    }
  }
  int error = 0;
  for (jointrig_params* B = P; B; B = (jointrig_params*)B->next) error |= B->error;
  return error;
}
