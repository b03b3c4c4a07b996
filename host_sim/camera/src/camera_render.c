/*
 * Synthetic ToF camera renderer. Ray casting against flat discs and the plate;
 * pixels whose corners and centre see one surface take that surface whole, the
 * others (edges, and every pixel near a small object) are supersampled on an
 * S x S grid, so the gray of an edge pixel is its area coverage to within 1/S^2.
 */
#include "camera/camera.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
/* Objects whose smaller image semi-axis is below this are supersampled over their whole box. */
#define SMALL_OBJECT_PX       6.0
#define MIN_SMALL_SUPERSAMPLE 16

/* ---- PRNG ---------------------------------------------------------------- */

static uint64_t splitmix64(uint64_t *x) {
    uint64_t z = (*x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

void camera_rng_seed(struct camera_rng *rng, uint64_t seed) {
    uint64_t x = seed;
    for (int i = 0; i < 4; ++i) {
        rng->s[i] = splitmix64(&x);
    }
}

static uint64_t rotl(uint64_t x, int k) {
    return (x << k) | (x >> (64 - k));
}

uint64_t camera_rng_next(struct camera_rng *rng) {
    uint64_t *s = rng->s;
    uint64_t result = rotl(s[1] * 5u, 7) * 9u;
    uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
}

double camera_rng_uniform(struct camera_rng *rng, double lo, double hi) {
    double u = (double)(camera_rng_next(rng) >> 11) * (1.0 / 9007199254740992.0);
    return lo + (hi - lo) * u;
}

double camera_rng_gauss(struct camera_rng *rng) {
    /* Box-Muller; u1 in (0, 1] so the log is finite. */
    double u1 = 1.0 - camera_rng_uniform(rng, 0.0, 1.0);
    double u2 = camera_rng_uniform(rng, 0.0, 1.0);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * PI * u2);
}

/* ---- geometry ------------------------------------------------------------- */

void camera_paper_intrinsics(struct camera_intrinsics *k) {
    /* Paper §2.1: 320 x 240, HFOV 52.4 deg, VFOV 40.6 deg; pixel centres at integers. */
    k->fx = 160.0 / tan(26.2 * PI / 180.0);
    k->fy = 120.0 / tan(20.3 * PI / 180.0);
    k->cx = 159.5;
    k->cy = 119.5;
}

void camera_scene_default(struct camera_scene *scene) {
    memset(scene, 0, sizeof *scene);
    camera_pose_from_angles(0.0, 0.0, 0.0, (const double[3]){0.0, 0.0, 700.0}, &scene->pose);
    scene->markers = pose_paper_target;
    scene->n_markers = POSE_PAPER_TARGET_COUNT;
    scene->marker_reflectance = 0.80;
    scene->plate_reflectance = 0.06;
    scene->plate_half_x = 220.0;
    scene->plate_half_y = 150.0;
}

static void mat_mul(const double a[3][3], const double b[3][3], double out[3][3]) {
    double tmp[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            tmp[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    memcpy(out, tmp, sizeof tmp);
}

void camera_pose_from_angles(double roll_deg, double pitch_deg, double yaw_deg, const double t[3],
                             struct camera_pose *pose) {
    double ar = roll_deg * PI / 180.0;
    double ap = pitch_deg * PI / 180.0;
    double ay = yaw_deg * PI / 180.0;
    double rx[3][3] = {{1, 0, 0}, {0, cos(ar), -sin(ar)}, {0, sin(ar), cos(ar)}};
    double ry[3][3] = {{cos(ap), 0, sin(ap)}, {0, 1, 0}, {-sin(ap), 0, cos(ap)}};
    double rz[3][3] = {{cos(ay), -sin(ay), 0}, {sin(ay), cos(ay), 0}, {0, 0, 1}};
    /* Facing the camera: target z toward the camera (-z_cam), target y up (-y_cam). */
    double face[3][3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    double m[3][3];
    mat_mul(rz, ry, m);
    mat_mul(m, rx, m);
    mat_mul(m, face, pose->r);
    memcpy(pose->t, t, sizeof pose->t);
}

double camera_rotation_error_deg(const double a[3][3], const float b[3][3]) {
    double m[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            m[i][j] =
                a[0][i] * (double)b[0][j] + a[1][i] * (double)b[1][j] + a[2][i] * (double)b[2][j];
        }
    }
    double c = m[0][0] + m[1][1] + m[2][2] - 1.0;
    double sx = m[2][1] - m[1][2];
    double sy = m[0][2] - m[2][0];
    double sz = m[1][0] - m[0][1];
    return atan2(sqrt(sx * sx + sy * sy + sz * sz), c) * 180.0 / PI;
}

static void apply_pose(const struct camera_pose *p, const double x[3], double out[3]) {
    for (int i = 0; i < 3; ++i) {
        out[i] = p->r[i][0] * x[0] + p->r[i][1] * x[1] + p->r[i][2] * x[2] + p->t[i];
    }
}

static void cross(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

enum object_kind { OBJ_DISC, OBJ_RECT };

struct object {
    enum object_kind kind;
    double centre[3], normal[3], axis_a[3], axis_b[3];
    double a, b;
    double reflectance;
    int box[4]; /* x0, y0, x1, y1 inclusive, clamped */
    bool small;
};

struct hit {
    int object; /* -1: nothing */
    double range;
};

static struct hit cast(const struct object *obj, int n, const double d[3], double dnorm) {
    struct hit h = {-1, 0.0};
    double best = INFINITY;
    for (int i = 0; i < n; ++i) {
        const struct object *o = &obj[i];
        double denom = dot(o->normal, d);
        if (fabs(denom) < 1e-15) {
            continue;
        }
        double tt = dot(o->normal, o->centre) / denom;
        if (tt <= 0.0 || tt >= best) {
            continue;
        }
        double p[3] = {tt * d[0] - o->centre[0], tt * d[1] - o->centre[1],
                       tt * d[2] - o->centre[2]};
        double x = dot(p, o->axis_a) / o->a;
        double y = dot(p, o->axis_b) / o->b;
        bool inside =
            (o->kind == OBJ_DISC) ? (x * x + y * y <= 1.0) : (fabs(x) <= 1.0 && fabs(y) <= 1.0);
        if (inside) {
            best = tt;
            h.object = i;
        }
    }
    if (h.object >= 0) {
        h.range = best * dnorm;
    }
    return h;
}

static void project(const struct camera_intrinsics *k, const double p[3], double *u, double *v) {
    *u = k->fx * p[0] / p[2] + k->cx;
    *v = k->fy * p[1] / p[2] + k->cy;
}

static void object_box(const struct camera_intrinsics *k, struct object *o) {
    double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
    double zmin = INFINITY;
    for (int s = 0; s < 72; ++s) {
        double ang = 2.0 * PI * s / 72.0;
        double ca = cos(ang), sa = sin(ang);
        if (o->kind == OBJ_RECT) {
            /* Walk the rectangle's outline. */
            double m = fmax(fabs(ca), fabs(sa));
            ca /= m;
            sa /= m;
        }
        double p[3];
        for (int i = 0; i < 3; ++i) {
            p[i] = o->centre[i] + o->a * ca * o->axis_a[i] + o->b * sa * o->axis_b[i];
        }
        if (p[2] < zmin) {
            zmin = p[2];
        }
        double u, v;
        project(k, p, &u, &v);
        umin = fmin(umin, u);
        umax = fmax(umax, u);
        vmin = fmin(vmin, v);
        vmax = fmax(vmax, v);
    }
    int x0 = (int)floor(umin) - 1, x1 = (int)ceil(umax) + 1;
    int y0 = (int)floor(vmin) - 1, y1 = (int)ceil(vmax) + 1;
    o->box[0] = x0 < 0 ? 0 : x0;
    o->box[1] = y0 < 0 ? 0 : y0;
    o->box[2] = x1 > CAMERA_WIDTH - 1 ? CAMERA_WIDTH - 1 : x1;
    o->box[3] = y1 > CAMERA_HEIGHT - 1 ? CAMERA_HEIGHT - 1 : y1;
    double minor_px = fmin(o->a, o->b) * k->fx / zmin;
    o->small = (o->kind == OBJ_DISC) && minor_px < SMALL_OBJECT_PX;
}

static void make_disc(struct object *o, const struct camera_disc *d) {
    o->kind = OBJ_DISC;
    memcpy(o->centre, d->centre, sizeof o->centre);
    memcpy(o->normal, d->normal, sizeof o->normal);
    memcpy(o->axis_a, d->axis, sizeof o->axis_a);
    cross(d->normal, d->axis, o->axis_b);
    o->a = d->a;
    o->b = d->b;
    o->reflectance = d->reflectance;
}

static uint16_t clamp_u16(double x, double hi) {
    if (!(x > 0.0)) {
        return 0;
    }
    if (x > hi) {
        x = hi;
    }
    return (uint16_t)lround(x);
}

void camera_render(const struct camera_intrinsics *k, const struct camera_scene *scene,
                   const struct camera_noise *noise, int supersample, struct camera_rng *rng,
                   struct camera_frame *frame, struct camera_truth *truth) {
    enum { MAX_OBJ = 1 + POSE_MAX_MARKERS + CAMERA_MAX_SPURIOUS };
    struct object obj[MAX_OBJ];
    int marker_object[POSE_MAX_MARKERS];
    int n = 0;
    const struct camera_pose *pose = &scene->pose;
    double z_axis[3] = {pose->r[0][2], pose->r[1][2], pose->r[2][2]};
    double x_axis[3] = {pose->r[0][0], pose->r[1][0], pose->r[2][0]};
    double y_axis[3] = {pose->r[0][1], pose->r[1][1], pose->r[2][1]};

    /* The plate: target origin, z normal. */
    memset(&obj[n], 0, sizeof obj[n]);
    obj[n].kind = OBJ_RECT;
    memcpy(obj[n].centre, pose->t, sizeof obj[n].centre);
    memcpy(obj[n].normal, z_axis, sizeof z_axis);
    memcpy(obj[n].axis_a, x_axis, sizeof x_axis);
    memcpy(obj[n].axis_b, y_axis, sizeof y_axis);
    obj[n].a = scene->plate_half_x;
    obj[n].b = scene->plate_half_y;
    obj[n].reflectance = scene->plate_reflectance;
    ++n;
    for (size_t m = 0; m < scene->n_markers && m < POSE_MAX_MARKERS; ++m) {
        marker_object[m] = -1;
        if (scene->hidden[m]) {
            continue;
        }
        struct camera_disc d;
        double p[3] = {scene->markers[m].position_mm[0], scene->markers[m].position_mm[1],
                       scene->markers[m].position_mm[2]};
        apply_pose(pose, p, d.centre);
        memcpy(d.normal, z_axis, sizeof z_axis);
        memcpy(d.axis, x_axis, sizeof x_axis);
        d.a = d.b = 0.5 * (double)scene->markers[m].diameter_mm;
        d.reflectance = scene->marker_reflectance;
        make_disc(&obj[n], &d);
        marker_object[m] = n;
        ++n;
    }
    for (size_t s = 0; s < scene->n_spurious && s < CAMERA_MAX_SPURIOUS; ++s) {
        make_disc(&obj[n], &scene->spurious[s]);
        ++n;
    }
    for (int i = 0; i < n; ++i) {
        object_box(k, &obj[i]);
    }
    obj[0].small = false;

    /* Surfaces seen through pixel corners (W+1 x H+1) and centres. */
    static int corner[CAMERA_HEIGHT + 1][CAMERA_WIDTH + 1];
    static unsigned char forced[CAMERA_HEIGHT][CAMERA_WIDTH];
    memset(forced, 0, sizeof forced);
    for (int i = 0; i < n; ++i) {
        if (!obj[i].small) {
            continue;
        }
        for (int y = obj[i].box[1]; y <= obj[i].box[3]; ++y) {
            for (int x = obj[i].box[0]; x <= obj[i].box[2]; ++x) {
                forced[y][x] = 1;
            }
        }
    }
    for (int y = 0; y <= CAMERA_HEIGHT; ++y) {
        for (int x = 0; x <= CAMERA_WIDTH; ++x) {
            double d[3] = {(x - 0.5 - k->cx) / k->fx, (y - 0.5 - k->cy) / k->fy, 1.0};
            corner[y][x] = cast(obj, n, d, sqrt(dot(d, d))).object;
        }
    }
    int s_norm = supersample < 1 ? 1 : supersample;
    int s_small = s_norm < MIN_SMALL_SUPERSAMPLE ? MIN_SMALL_SUPERSAMPLE : s_norm;
    uint32_t supersampled = 0;
    for (int y = 0; y < CAMERA_HEIGHT; ++y) {
        for (int x = 0; x < CAMERA_WIDTH; ++x) {
            double dc[3] = {(x - k->cx) / k->fx, (y - k->cy) / k->fy, 1.0};
            struct hit centre = cast(obj, n, dc, sqrt(dot(dc, dc)));
            int id = centre.object;
            bool uniform = !forced[y][x] && corner[y][x] == id && corner[y][x + 1] == id &&
                           corner[y + 1][x] == id && corner[y + 1][x + 1] == id;
            double gray_sum = 0.0;
            double range_weighted = 0.0;
            if (uniform) {
                if (id >= 0) {
                    gray_sum = obj[id].reflectance;
                    range_weighted = obj[id].reflectance * centre.range;
                }
            } else {
                ++supersampled;
                int s = forced[y][x] ? s_small : s_norm;
                for (int sy = 0; sy < s; ++sy) {
                    for (int sx = 0; sx < s; ++sx) {
                        double u = x - 0.5 + (sx + 0.5) / s;
                        double v = y - 0.5 + (sy + 0.5) / s;
                        double d[3] = {(u - k->cx) / k->fx, (v - k->cy) / k->fy, 1.0};
                        struct hit h = cast(obj, n, d, sqrt(dot(d, d)));
                        if (h.object >= 0) {
                            gray_sum += obj[h.object].reflectance;
                            range_weighted += obj[h.object].reflectance * h.range;
                        }
                    }
                }
                gray_sum /= (double)(s * s);
                range_weighted /= (double)(s * s);
            }
            double gray = gray_sum * CAMERA_FULL_SCALE;
            double range = gray_sum > 0.0 ? range_weighted / gray_sum : 0.0;
            if (noise != NULL && rng != NULL) {
                if (noise->gray_sigma > 0.0) {
                    gray += noise->gray_sigma * CAMERA_FULL_SCALE * camera_rng_gauss(rng);
                }
                if (noise->range_sigma > 0.0 && range > 0.0) {
                    range += noise->range_sigma * range * camera_rng_gauss(rng);
                    if (range < 1.0) {
                        range = 1.0; /* a return stays a return */
                    }
                }
            }
            frame->gray[y][x] = clamp_u16(gray, CAMERA_FULL_SCALE);
            frame->range_mm[y][x] = clamp_u16(range, 65535.0);
        }
    }

    if (truth == NULL) {
        return;
    }
    memset(truth, 0, sizeof *truth);
    truth->supersampled_pixels = supersampled;
    for (size_t m = 0; m < scene->n_markers && m < POSE_MAX_MARKERS; ++m) {
        struct camera_marker_truth *mt = &truth->markers[m];
        double p[3] = {scene->markers[m].position_mm[0], scene->markers[m].position_mm[1],
                       scene->markers[m].position_mm[2]};
        double c[3];
        apply_pose(pose, p, c);
        project(k, c, &mt->u, &mt->v);
        double r = 0.5 * (double)scene->markers[m].diameter_mm;
        /* Ellipse centre: c ~ C_z C - r^2 (z - n_z n) (see pose_circle_image_centre). */
        double nz = z_axis[2];
        double vx = c[2] * c[0] + r * r * nz * z_axis[0];
        double vy = c[2] * c[1] + r * r * nz * z_axis[1];
        double vz = c[2] * c[2] - r * r * (1.0 - nz * nz);
        mt->ue = k->fx * vx / vz + k->cx;
        mt->ve = k->fy * vy / vz + k->cy;
        mt->radius_px = r * k->fx / c[2];
        mt->range_mm = sqrt(dot(c, c));
        mt->in_scene = !scene->hidden[m];
        if (mt->in_scene) {
            const struct object *o = &obj[marker_object[m]];
            double d[3] = {c[0] / c[2], c[1] / c[2], 1.0};
            struct hit h = cast(obj, n, d, 1.0);
            bool inside = o->box[0] > 0 && o->box[1] > 0 && o->box[2] < CAMERA_WIDTH - 1 &&
                          o->box[3] < CAMERA_HEIGHT - 1;
            mt->visible = (h.object == marker_object[m]) && inside;
        }
    }
    for (size_t s = 0; s < scene->n_spurious && s < CAMERA_MAX_SPURIOUS; ++s) {
        project(k, scene->spurious[s].centre, &truth->spurious_u[s], &truth->spurious_v[s]);
    }
}
