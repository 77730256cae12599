struct LlFrame {
    float3 u;
    int _pad1_0;
    float3 c_hat;
    float d;
    float l_b;
    float l_e;
    bool valid;
    int _end_pad_0;
};

struct LlArc {
    float3 u;
    int _pad1_0;
    float3 c_hat;
    float d;
    float s_b;
    float c_b;
    float width;
    float s_e;
    float c_e;
    int _end_pad_0;
    int _end_pad_1;
    int _end_pad_2;
};

struct LlClipped {
    LlArc arc;
    float delta_s;
    float pdf;
    bool valid;
    int _end_pad_0;
};

struct LlSample {
    float3 dir;
    float pdf;
};

struct LlPsaCore {
    float ns;
    float nt;
    float s_b;
    float c_b;
    float delta_s;
    float width;
    float p0_;
    float p1_;
    float total;
};

struct LlPsaEval {
    float delta_c_cos;
    float delta_c_lin;
    float s2_;
    float t2_;
    float n_dot_w;
    float n_dot_w_prime;
};

struct LlPsa {
    LlArc arc;
    float3 n;
    LlPsaCore core;
    float inv_psa;
    bool valid;
    int _end_pad_0;
    int _end_pad_1;
};

struct LlLtc {
    LlArc arc;
    row_major float3x3 to_shading;
    int _pad2_0;
    row_major float3x3 a;
    int _pad3_0;
    row_major float3x3 to_world;
    int _pad4_0;
    LlPsa transformed;
    float kappa;
    float scale;
    bool valid;
    int _end_pad_0;
};

struct LlLtcEntry {
    row_major float3x3 a;
    int _pad1_0;
    float rho;
    int _end_pad_0;
    int _end_pad_1;
    int _end_pad_2;
};

struct LlParams {
    uint mode;
    uint count;
    uint samples;
    uint steps;
    float4 light_begin;
    float4 light_end;
};

static const float LL_PI = 3.1415927;
static const float LL_HALF_PI_HI = 1.5707964;
static const float LL_HALF_PI_LO = -4.371139e-8;
static const float LL_QUARTER_PI = 0.7853982;
static const float LL_TAN_PI_8_ = 0.41421357;
static const uint LL_HALLEY_STEPS = 2u;
static const float LL_XI_GUARD = 1e-5;
static const float LL_PDF_SCALE = 1.0;
static const float LL_XI_LATTICE_START = 2.9802322e-8;
static const float LL_XI_LATTICE_END = 0.99999994;
static const float LL_MIN_RELATIVE_DISTANCE = 1e-7;
static const float LL_MAX_ILL_CONDITION = 10000000.0;

ByteAddressBuffer ll_ltc_table : register(t3);
cbuffer ll_params : register(b0) { LlParams ll_params; }
ByteAddressBuffer ll_queries : register(t1);
RWByteAddressBuffer ll_answers : register(u2);

float2 ll_sin_cos(float x)
{
    bool upper = (x > LL_QUARTER_PI);
    float y_2 = (upper ? ((LL_HALF_PI_HI - x) + LL_HALF_PI_LO) : x);
    float y2_ = (y_2 * y_2);
    float s_1 = (y_2 * (1.0 - ((y2_ / 6.0) * (1.0 - ((y2_ / 20.0) * (1.0 - ((y2_ / 42.0) * (1.0 - ((y2_ / 72.0) * (1.0 - (y2_ / 110.0)))))))))));
    float c_16 = (1.0 - ((y2_ / 2.0) * (1.0 - ((y2_ / 12.0) * (1.0 - ((y2_ / 30.0) * (1.0 - ((y2_ / 56.0) * (1.0 - ((y2_ / 90.0) * (1.0 - (y2_ / 132.0))))))))))));
    return (upper ? float2(c_16, s_1) : float2(s_1, c_16));
}

float ll_atan_unit(float a)
{
    float p = 0.05882353;

    bool upper_1 = (a > LL_TAN_PI_8_);
    float b_3 = (upper_1 ? ((a - 1.0) / (a + 1.0)) : a);
    float b2_ = (b_3 * b_3);
    float _e12 = p;
    p = (0.06666667 - (b2_ * _e12));
    float _e16 = p;
    p = (0.07692308 - (b2_ * _e16));
    float _e20 = p;
    p = (0.09090909 - (b2_ * _e20));
    float _e24 = p;
    p = (0.11111111 - (b2_ * _e24));
    float _e28 = p;
    p = (0.14285715 - (b2_ * _e28));
    float _e32 = p;
    p = (0.2 - (b2_ * _e32));
    float _e36 = p;
    p = (0.33333334 - (b2_ * _e36));
    float _e41 = p;
    float r_1 = (b_3 - ((b_3 * b2_) * _e41));
    return (upper_1 ? (LL_QUARTER_PI + r_1) : r_1);
}

float ll_atan2_(float y, float x_1)
{
    float r = (float)0;

    float ax = abs(x_1);
    float ay = abs(y);
    float mx = max(ax, ay);
    float mn = min(ax, ay);
    float a_11 = ((mx == 0.0) ? 0.0 : (mn / mx));
    const float _e11 = ll_atan_unit(a_11);
    r = _e11;
    float _e13 = r;
    float _e15 = r;
    r = ((ay > ax) ? ((LL_HALF_PI_HI - _e15) + LL_HALF_PI_LO) : _e13);
    float _e21 = r;
    float _e23 = r;
    r = ((x_1 < 0.0) ? (LL_PI - _e23) : _e21);
    float _e28 = r;
    float _e29 = r;
    return ((y < 0.0) ? -(_e29) : _e28);
}

int3 ll_unpack(float x_2)
{
    uint bits = asuint(x_2);
    int biased = int(((bits >> 23u) & 255u));
    uint m_1 = ((bits & 8388607u) | ((biased != int(0)) ? 8388608u : 0u));
    return int3(int(m_1), asint(asuint(max(biased, int(1))) - asuint(int(150))), int((bits >> 31u)));
}

uint2 ll_fixed_negate(uint2 x_3)
{
    uint lo_1 = (~(x_3.x) + 1u);
    return uint2(lo_1, (~(x_3.y) + ((lo_1 == 0u) ? 1u : 0u)));
}

uint2 ll_fixed_add(uint2 x_4, uint2 y_1)
{
    uint lo_2 = (x_4.x + y_1.x);
    return uint2(lo_2, ((x_4.y + y_1.y) + ((lo_2 < x_4.x) ? 1u : 0u)));
}

int naga_neg(int val) {
    return asint(-asuint(val));
}

uint2 ll_fixed_product(float a_1, float b)
{
    uint2 p_1 = (uint2)0;

    const int3 _e2 = ll_unpack(a_1);
    const int3 _e3 = ll_unpack(b);
    uint a1_1 = (uint(_e2.x) >> 12u);
    uint a0_1 = (uint(_e2.x) & 4095u);
    uint b1_ = (uint(_e3.x) >> 12u);
    uint b0_ = (uint(_e3.x) & 4095u);
    uint hh = (a1_1 * b1_);
    uint mid = ((a1_1 * b0_) + (a0_1 * b1_));
    const uint2 _e32 = ll_fixed_add(uint2((a0_1 * b0_), 0u), uint2((mid << 12u), (mid >> 20u)));
    p_1 = _e32;
    uint2 _e34 = p_1;
    const uint2 _e40 = ll_fixed_add(_e34, uint2((hh << 24u), (hh >> 8u)));
    p_1 = _e40;
    int s_2 = asint(asuint(asint(asuint(_e2.y) + asuint(_e3.y))) + asuint(int(60)));
    if ((s_2 > int(0))) {
        uint k_5 = uint(s_2);
        uint _e50 = p_1.x;
        uint _e53 = p_1.y;
        uint _e56 = p_1.x;
        p_1 = uint2((_e50 << k_5), ((_e53 << k_5) | (_e56 >> (32u - k_5))));
    } else {
        if ((s_2 < int(0))) {
            uint r_2 = uint(naga_neg(s_2));
            if ((r_2 >= 64u)) {
                p_1 = uint2(0u, 0u);
            } else {
                if ((r_2 >= 32u)) {
                    uint _e74 = p_1.y;
                    p_1 = uint2((_e74 >> (r_2 - 32u)), 0u);
                } else {
                    uint _e81 = p_1.x;
                    uint _e84 = p_1.y;
                    uint _e90 = p_1.y;
                    p_1 = uint2(((_e81 >> r_2) | (_e84 << (32u - r_2))), (_e90 >> r_2));
                }
            }
        }
    }
    uint2 _e93 = p_1;
    uint2 _e94 = p_1;
    const uint2 _e95 = ll_fixed_negate(_e94);
    return (((_e2.z ^ _e3.z) != int(0)) ? _e95 : _e93);
}

float ll_fixed_to_f32_(uint2 x_5)
{
    bool negative = ((x_5.y >> 31u) != 0u);
    const uint2 _e6 = ll_fixed_negate(x_5);
    uint2 m_2 = (negative ? _e6 : x_5);
    float v_1 = ((float(m_2.y) * 3.7252903e-9) + (float(m_2.x) * 8.6736174e-19));
    return (negative ? -(v_1) : v_1);
}

float ll_dot2_(float a_2, float b_1, float c, float d)
{
    const uint2 _e4 = ll_fixed_product(a_2, b_1);
    const uint2 _e5 = ll_fixed_product(c, d);
    const uint2 _e6 = ll_fixed_add(_e4, _e5);
    const float _e7 = ll_fixed_to_f32_(_e6);
    return _e7;
}

LlFrame ll_frame(float3 begin, float3 end, float3 x_6)
{
    LlFrame f = (LlFrame)0;
    float3 c_1 = (float3)0;
    bool local = (bool)0;
    bool local_1 = (bool)0;
    bool local_2 = (bool)0;

    float3 b_4 = (begin - x_6);
    float3 e_4 = (end - x_6);
    float3 axis = (e_4 - b_4);
    float length2_ = dot(axis, axis);
    float length_ = sqrt(length2_);
    f.u = (axis / (length_).xxx);
    bool from_end = (dot(e_4, e_4) < dot(b_4, b_4));
    float3 p_9 = (from_end ? e_4 : b_4);
    float3 _e17 = f.u;
    float3 _e20 = f.u;
    c_1 = (p_9 - (dot(_e17, p_9) * _e20));
    float3 _e24 = c_1;
    float3 _e26 = f.u;
    float3 _e27 = c_1;
    float3 _e30 = f.u;
    c_1 = (_e24 - (dot(_e26, _e27) * _e30));
    float3 _e33 = c_1;
    float3 _e34 = c_1;
    float d2_ = dot(_e33, _e34);
    f.d = sqrt(d2_);
    float3 _e39 = c_1;
    float _e41 = f.d;
    f.c_hat = (_e39 / (_e41).xxx);
    float3 _e45 = f.u;
    float lp = dot(_e45, p_9);
    f.l_b = (from_end ? (lp - length_) : lp);
    f.l_e = (from_end ? lp : (lp + length_));
    float scale2_ = max(length2_, max(dot(b_4, b_4), dot(e_4, e_4)));
    if ((length2_ > 0.0)) {
        local = (d2_ > ((LL_MIN_RELATIVE_DISTANCE * LL_MIN_RELATIVE_DISTANCE) * scale2_));
    } else {
        local = false;
    }
    bool _e67 = local;
    if (_e67) {
        float _e71 = f.l_e;
        float _e73 = f.l_b;
        local_1 = (_e71 > _e73);
    } else {
        local_1 = false;
    }
    bool _e76 = local_1;
    if (_e76) {
        float _e80 = f.d;
        local_2 = (_e80 > 0.0);
    } else {
        local_2 = false;
    }
    bool _e84 = local_2;
    f.valid = _e84;
    LlFrame _e85 = f;
    const LlFrame llframe = _e85;
    return llframe;
}

LlFrame ll_frame_clip(LlFrame f_in, float3 n)
{
    LlFrame f_1 = (LlFrame)0;
    bool local_3 = (bool)0;
    bool local_4 = (bool)0;
    bool local_5 = (bool)0;
    bool local_6 = (bool)0;
    bool local_7 = (bool)0;

    f_1 = f_in;
    float _e4 = f_1.d;
    float3 _e6 = f_1.c_hat;
    float nc = (_e4 * dot(n, _e6));
    float3 _e10 = f_1.u;
    float nu = dot(n, _e10);
    float _e13 = f_1.l_b;
    float hb = (nc + (_e13 * nu));
    float _e17 = f_1.l_e;
    float he = (nc + (_e17 * nu));
    float root = (-(nc) / nu);
    float _e24 = f_1.l_b;
    float _e26 = f_1.l_b;
    if ((hb < 0.0)) {
        local_3 = (he > 0.0);
    } else {
        local_3 = false;
    }
    bool _e35 = local_3;
    f_1.l_b = (_e35 ? max(root, _e26) : _e24);
    float _e39 = f_1.l_e;
    float _e41 = f_1.l_e;
    if ((he < 0.0)) {
        local_4 = (hb > 0.0);
    } else {
        local_4 = false;
    }
    bool _e50 = local_4;
    f_1.l_e = (_e50 ? min(root, _e41) : _e39);
    bool _e54 = f_1.valid;
    if (_e54) {
        if (!((hb > 0.0))) {
            local_6 = (he > 0.0);
        } else {
            local_6 = true;
        }
        bool _e65 = local_6;
        local_5 = _e65;
    } else {
        local_5 = false;
    }
    bool _e67 = local_5;
    if (_e67) {
        float _e71 = f_1.l_e;
        float _e73 = f_1.l_b;
        local_7 = (_e71 > _e73);
    } else {
        local_7 = false;
    }
    bool _e76 = local_7;
    f_1.valid = _e76;
    LlFrame _e77 = f_1;
    const LlFrame llframe_1 = _e77;
    return llframe_1;
}

LlArc ll_arc(LlFrame f_2)
{
    LlArc a_3 = (LlArc)0;

    a_3.u = f_2.u;
    a_3.c_hat = f_2.c_hat;
    a_3.d = f_2.d;
    float r_b = sqrt(((f_2.l_b * f_2.l_b) + (f_2.d * f_2.d)));
    a_3.s_b = (f_2.l_b / r_b);
    a_3.c_b = (f_2.d / r_b);
    const float _e34 = ll_atan2_(((f_2.l_e - f_2.l_b) * f_2.d), mad(f_2.l_b, f_2.l_e, (f_2.d * f_2.d)));
    a_3.width = _e34;
    float r_e = sqrt(((f_2.l_e * f_2.l_e) + (f_2.d * f_2.d)));
    a_3.s_e = (f_2.l_e / r_e);
    a_3.c_e = (f_2.d / r_e);
    LlArc _e49 = a_3;
    const LlArc llarc = _e49;
    return llarc;
}

float2 ll_arc_rotate(LlArc a_4, float sin_tau, float cos_tau)
{
    return float2(((a_4.s_b * cos_tau) + (a_4.c_b * sin_tau)), ((a_4.c_b * cos_tau) - (a_4.s_b * sin_tau)));
}

float3 ll_arc_direction(LlArc a_5, float tau)
{
    const float2 _e7 = ll_sin_cos((0.5 * clamp(tau, 0.0, a_5.width)));
    const float2 _e20 = ll_arc_rotate(a_5, ((2.0 * _e7.x) * _e7.y), (1.0 - ((2.0 * _e7.x) * _e7.x)));
    return ((_e20.x * a_5.u) + (max(_e20.y, 0.0) * a_5.c_hat));
}

float ll_angle_from(float s, float t, float sin_r, float cos_r)
{
    const float _e10 = ll_atan2_(((s * cos_r) - (t * sin_r)), ((t * cos_r) + (s * sin_r)));
    return _e10;
}

float ll_arc_tau(LlArc a_6, float3 dir)
{
    const float _e10 = ll_angle_from(dot(a_6.u, dir), max(dot(a_6.c_hat, dir), 0.0), a_6.s_b, a_6.c_b);
    return _e10;
}

bool ll_arc_contains(LlArc a_7, float3 dir_1)
{
    bool local_8 = (bool)0;
    bool local_9 = (bool)0;

    float s_3 = dot(a_7.u, dir_1);
    float t_1 = dot(a_7.c_hat, dir_1);
    float tol = (2.5e-7 + (1e-6 * a_7.width));
    if ((t_1 >= 0.0)) {
        const float _e17 = ll_angle_from(s_3, t_1, a_7.s_b, a_7.c_b);
        local_8 = (_e17 >= -(tol));
    } else {
        local_8 = false;
    }
    bool _e21 = local_8;
    if (_e21) {
        const float _e26 = ll_angle_from(s_3, t_1, a_7.s_e, a_7.c_e);
        local_9 = (_e26 <= tol);
    } else {
        local_9 = false;
    }
    bool _e29 = local_9;
    return _e29;
}

float ll_arc_delta_s(LlArc a_8, float tau_1)
{
    const float2 _e4 = ll_sin_cos((0.5 * tau_1));
    return ((2.0 * _e4.x) * ((a_8.c_b * _e4.y) - (a_8.s_b * _e4.x)));
}

LlClipped ll_clipped_prepare(float3 begin_1, float3 end_1, float3 x_7, float3 n_1)
{
    LlClipped c_2 = (LlClipped)0;
    bool local_10 = (bool)0;
    bool local_11 = (bool)0;
    bool local_12 = (bool)0;
    bool local_13 = (bool)0;

    const LlFrame _e5 = ll_frame(begin_1, end_1, x_7);
    const LlFrame _e6 = ll_frame_clip(_e5, n_1);
    const LlArc _e8 = ll_arc(_e6);
    c_2.arc = _e8;
    LlArc _e11 = c_2.arc;
    float _e14 = c_2.arc.width;
    const float _e15 = ll_arc_delta_s(_e11, _e14);
    c_2.delta_s = _e15;
    float _e19 = c_2.arc.d;
    float _e21 = c_2.delta_s;
    c_2.pdf = (_e19 / (2.0 * _e21));
    if (_e6.valid) {
        float _e31 = c_2.arc.width;
        local_10 = (_e31 > 0.0);
    } else {
        local_10 = false;
    }
    bool _e35 = local_10;
    if (_e35) {
        float _e39 = c_2.delta_s;
        local_11 = (_e39 > 0.0);
    } else {
        local_11 = false;
    }
    bool _e43 = local_11;
    if (_e43) {
        float _e47 = c_2.pdf;
        local_12 = (_e47 > 0.0);
    } else {
        local_12 = false;
    }
    bool _e51 = local_12;
    if (_e51) {
        float _e55 = c_2.pdf;
        local_13 = (_e55 < 3e38);
    } else {
        local_13 = false;
    }
    bool _e59 = local_13;
    c_2.valid = _e59;
    LlClipped _e60 = c_2;
    const LlClipped llclipped = _e60;
    return llclipped;
}

float ll_clipped_tau(LlClipped c_3, float xi)
{
    float tau_2 = (float)0;

    LlArc a_12 = c_3.arc;
    float y_3 = (clamp(xi, 0.0, 1.0) * c_3.delta_s);
    float q = (y_3 * ((2.0 * a_12.s_b) + y_3));
    float cc = sqrt(max(((a_12.c_b * a_12.c_b) - q), 0.0));
    float denom = (a_12.c_b + cc);
    float sin_tau_1 = ((denom > 0.0) ? ((y_3 * a_12.c_b) + ((a_12.s_b * q) / denom)) : y_3);
    float cos_tau_1 = ((cc * a_12.c_b) + ((a_12.s_b + y_3) * a_12.s_b));
    const float _e38 = ll_atan2_(sin_tau_1, cos_tau_1);
    tau_2 = clamp(_e38, 0.0, a_12.width);
    float _e43 = tau_2;
    tau_2 = ((xi <= 0.0) ? 0.0 : _e43);
    float _e48 = tau_2;
    return ((xi >= 1.0) ? a_12.width : _e48);
}

LlSample ConstructLlSample(float3 arg0, float arg1) {
    LlSample ret = (LlSample)0;
    ret.dir = arg0;
    ret.pdf = arg1;
    return ret;
}

LlSample ll_clipped_sample(LlClipped c_4, float xi_1)
{
    const float _e3 = ll_clipped_tau(c_4, xi_1);
    const float3 _e4 = ll_arc_direction(c_4.arc, _e3);
    const LlSample llsample = ConstructLlSample(_e4, (c_4.pdf * LL_PDF_SCALE));
    return llsample;
}

float ll_clipped_pdf(LlClipped c_5, float3 dir_2)
{
    const bool _e6 = ll_arc_contains(c_5.arc, dir_2);
    return (_e6 ? (c_5.pdf * LL_PDF_SCALE) : 0.0);
}

float ll_clipped_inverse(LlClipped c_6, float3 dir_3)
{
    const float _e3 = ll_arc_tau(c_6.arc, dir_3);
    float tau_11 = clamp(_e3, 0.0, c_6.arc.width);
    const float _e9 = ll_arc_delta_s(c_6.arc, tau_11);
    return clamp((_e9 / c_6.delta_s), 0.0, 1.0);
}

float ll_delta_minus_sin(float x_8, float sin_x)
{
    float x2_ = (x_8 * x_8);
    float series = (((x_8 * x2_) / 6.0) * (1.0 - ((x2_ / 20.0) * (1.0 - ((x2_ / 42.0) * (1.0 - ((x2_ / 72.0) * (1.0 - (x2_ / 110.0)))))))));
    return ((abs(x_8) < 1.0) ? series : (x_8 - sin_x));
}

float2 ll_psa_delta_c_parts(LlPsaCore c_7, float tau_3, float sh, float ch)
{
    float cm = ((c_7.c_b * ch) - (c_7.s_b * sh));
    float n_dot_wm = ((c_7.p0_ * ch) + (c_7.p1_ * sh));
    float sin_tau_2 = ((2.0 * sh) * ch);
    const float _e22 = ll_delta_minus_sin(tau_3, sin_tau_2);
    return float2(((cm * n_dot_wm) * (2.0 * sin_tau_2)), (c_7.nt * _e22));
}

LlPsaCore ll_psa_core(float ns, float nt, float s_b, float c_b, float width)
{
    LlPsaCore c_8 = (LlPsaCore)0;

    c_8.ns = ns;
    c_8.nt = nt;
    c_8.s_b = s_b;
    c_8.c_b = c_b;
    c_8.width = width;
    const float _e12 = ll_dot2_(ns, s_b, nt, c_b);
    c_8.p0_ = max(_e12, 0.0);
    const float _e17 = ll_dot2_(ns, c_b, -(nt), s_b);
    c_8.p1_ = _e17;
    const float2 _e20 = ll_sin_cos((0.5 * width));
    c_8.delta_s = ((2.0 * ((c_b * _e20.y) - (s_b * _e20.x))) * _e20.x);
    LlPsaCore _e31 = c_8;
    const float2 _e34 = ll_psa_delta_c_parts(_e31, width, _e20.x, _e20.y);
    c_8.total = (_e34.x + _e34.y);
    LlPsaCore _e39 = c_8;
    const LlPsaCore llpsacore = _e39;
    return llpsacore;
}

LlPsaEval ll_psa_eval_half(LlPsaCore c_9, float tau_4, float sh_1, float ch_1)
{
    LlPsaEval e = (LlPsaEval)0;

    float sin_tau_3 = ((2.0 * sh_1) * ch_1);
    float cos_tau_2 = (1.0 - ((2.0 * sh_1) * sh_1));
    const float2 _e13 = ll_psa_delta_c_parts(c_9, tau_4, sh_1, ch_1);
    e.delta_c_cos = _e13.x;
    e.delta_c_lin = _e13.y;
    e.s2_ = (((2.0 * c_9.s_b) * cos_tau_2) + ((2.0 * c_9.c_b) * sin_tau_3));
    e.t2_ = (((2.0 * c_9.c_b) * cos_tau_2) - ((2.0 * c_9.s_b) * sin_tau_3));
    e.n_dot_w = ((c_9.p0_ * cos_tau_2) + (c_9.p1_ * sin_tau_3));
    e.n_dot_w_prime = ((c_9.p1_ * cos_tau_2) - (c_9.p0_ * sin_tau_3));
    LlPsaEval _e50 = e;
    const LlPsaEval llpsaeval = _e50;
    return llpsaeval;
}

float3 ll_psa_start(LlPsaCore c_10, float xi_2)
{
    float tau_5 = (float)0;

    float y_4 = (xi_2 * c_10.delta_s);
    float wy = ((2.0 * c_10.s_b) + y_4);
    float q_1 = (y_4 * wy);
    float cc_1 = sqrt(max(((c_10.c_b * c_10.c_b) - q_1), 0.0));
    float denom_1 = (c_10.c_b + cc_1);
    bool scaled = (denom_1 > 0.0);
    float sin_tau_4 = (scaled ? (((y_4 * c_10.c_b) * denom_1) + (c_10.s_b * q_1)) : y_4);
    float cos_tau_3 = ((scaled ? denom_1 : 1.0) * ((cc_1 * c_10.c_b) + ((c_10.s_b + y_4) * c_10.s_b)));
    const float _e37 = ll_atan2_(sin_tau_4, cos_tau_3);
    tau_5 = clamp(_e37, 0.0, c_10.width);
    float _e42 = tau_5;
    tau_5 = ((xi_2 <= 0.0) ? 0.0 : _e42);
    float _e47 = tau_5;
    tau_5 = ((xi_2 >= 1.0) ? c_10.width : _e47);
    float w_1 = sqrt(((denom_1 * denom_1) + (wy * wy)));
    float sh_2 = (scaled ? (sin_tau_4 / (denom_1 * w_1)) : ((cos_tau_3 < 0.0) ? 1.0 : 0.0));
    float _e64 = tau_5;
    return float3(_e64, sh_2, (0.5 * w_1));
}

float2 ll_psa_halley_terms(LlPsaCore c_11, float xi_3, LlPsaEval e_1)
{
    float g_1 = (e_1.delta_c_cos + (e_1.delta_c_lin - (xi_3 * c_11.total)));
    float g1_ = (e_1.t2_ * e_1.n_dot_w);
    float g2_ = ((e_1.t2_ * e_1.n_dot_w_prime) - (e_1.s2_ * e_1.n_dot_w));
    float den_1 = (max(g1_, 0.0) + sqrt(max(((g1_ * g1_) - (g_1 * (2.0 * g2_))), 0.0)));
    return float2(g_1, den_1);
}

float ll_psa_step(float tau_6, float limit, float g, float den, float scale)
{
    float stepped = clamp((tau_6 - ((scale * g) / den)), 0.0, limit);
    float end_4 = ((g < 0.0) ? limit : ((g > 0.0) ? 0.0 : tau_6));
    return ((den > 0.0) ? stepped : end_4);
}

float ll_psa_solve(LlPsaCore c_12, float xi_4, uint steps)
{
    bool local_14 = (bool)0;
    bool local_15 = (bool)0;
    float tau_7 = (float)0;
    LlPsaEval e_2 = (LlPsaEval)0;
    uint i = 1u;

    const float3 _e3 = ll_psa_start(c_12, xi_4);
    if (!((steps == 0u))) {
        local_14 = (xi_4 < LL_XI_GUARD);
    } else {
        local_14 = true;
    }
    bool _e12 = local_14;
    if (!(_e12)) {
        local_15 = (xi_4 > 0.99999);
    } else {
        local_15 = true;
    }
    bool _e19 = local_15;
    if (_e19) {
        return _e3.x;
    }
    tau_7 = _e3.x;
    float _e23 = tau_7;
    const LlPsaEval _e26 = ll_psa_eval_half(c_12, _e23, _e3.y, _e3.z);
    e_2 = _e26;
    uint2 loop_bound = uint2(4294967295u, 4294967295u);
    bool loop_init = true;
    while(true) {
        if (all(loop_bound == uint2(0u, 0u))) { break; }
        loop_bound -= uint2(loop_bound.y == 0u, 1u);
        if (!loop_init) {
            uint _e52 = i;
            i = (_e52 + 1u);
        }
        loop_init = false;
        uint _e30 = i;
        if ((_e30 < steps)) {
        } else {
            break;
        }
        {
            LlPsaEval _e32 = e_2;
            const float2 _e33 = ll_psa_halley_terms(c_12, xi_4, _e32);
            float _e34 = tau_7;
            const float _e43 = ll_psa_step((0.5 * _e34), (0.5 * c_12.width), _e33.x, _e33.y, 1.0);
            tau_7 = (2.0 * _e43);
            const float2 _e46 = ll_sin_cos(_e43);
            float _e47 = tau_7;
            const LlPsaEval _e50 = ll_psa_eval_half(c_12, _e47, _e46.x, _e46.y);
            e_2 = _e50;
        }
    }
    LlPsaEval _e54 = e_2;
    const float2 _e55 = ll_psa_halley_terms(c_12, xi_4, _e54);
    float _e56 = tau_7;
    const float _e61 = ll_psa_step(_e56, c_12.width, _e55.x, _e55.y, 2.0);
    return _e61;
}

float ll_psa_solve_converged(LlPsaCore c_13, float xi_5)
{
    float lo = 0.0;
    float hi = (float)0;
    float tau_8 = (float)0;
    uint i_1 = 0u;
    bool local_16 = (bool)0;
    bool local_17 = (bool)0;

    hi = c_13.width;
    const float3 _e6 = ll_psa_start(c_13, xi_5);
    tau_8 = _e6.x;
    uint2 loop_bound_1 = uint2(4294967295u, 4294967295u);
    bool loop_init_1 = true;
    while(true) {
        if (all(loop_bound_1 == uint2(0u, 0u))) { break; }
        loop_bound_1 -= uint2(loop_bound_1.y == 0u, 1u);
        if (!loop_init_1) {
            uint _e71 = i_1;
            i_1 = (_e71 + 1u);
        }
        loop_init_1 = false;
        uint _e11 = i_1;
        if ((_e11 < 24u)) {
        } else {
            break;
        }
        {
            float _e14 = tau_8;
            const float2 _e17 = ll_sin_cos((0.5 * _e14));
            float _e18 = tau_8;
            const LlPsaEval _e21 = ll_psa_eval_half(c_13, _e18, _e17.x, _e17.y);
            const float2 _e22 = ll_psa_halley_terms(c_13, xi_5, _e21);
            float _e23 = lo;
            float _e24 = tau_8;
            lo = ((_e22.x < 0.0) ? _e24 : _e23);
            float _e29 = hi;
            float _e30 = tau_8;
            hi = ((_e22.x > 0.0) ? _e30 : _e29);
            float _e35 = tau_8;
            const float _e40 = ll_psa_step(_e35, c_13.width, _e22.x, _e22.y, 2.0);
            float _e41 = lo;
            if ((_e40 > _e41)) {
                float _e45 = hi;
                local_16 = (_e40 < _e45);
            } else {
                local_16 = false;
            }
            bool inside = local_16;
            float _e49 = tau_8;
            float _e52 = tau_8;
            if (!((abs((_e40 - _e49)) <= (2.4e-7 * _e52)))) {
                local_17 = (_e22.x == 0.0);
            } else {
                local_17 = true;
            }
            bool converged = local_17;
            float _e64 = lo;
            float _e65 = hi;
            tau_8 = (inside ? _e40 : (0.5 * (_e64 + _e65)));
            if (converged) {
                break;
            }
        }
    }
    float _e73 = tau_8;
    return ((xi_5 <= 0.0) ? 0.0 : ((xi_5 >= 1.0) ? c_13.width : _e73));
}

float ll_psa_cdf(LlPsaCore c_14, float tau_9)
{
    float t_2 = clamp(tau_9, 0.0, c_14.width);
    const float2 _e7 = ll_sin_cos((0.5 * t_2));
    const float2 _e10 = ll_psa_delta_c_parts(c_14, t_2, _e7.x, _e7.y);
    return clamp(((_e10.x + _e10.y) / c_14.total), 0.0, 1.0);
}

LlPsa ll_psa_on_frame(LlFrame f_3, float3 n_2)
{
    LlPsa p_2 = (LlPsa)0;
    bool local_18 = (bool)0;
    bool local_19 = (bool)0;
    bool local_20 = (bool)0;
    bool local_21 = (bool)0;

    const LlArc _e4 = ll_arc(f_3);
    p_2.arc = _e4;
    p_2.n = n_2;
    float _e13 = p_2.arc.s_b;
    float _e16 = p_2.arc.c_b;
    float _e19 = p_2.arc.width;
    const LlPsaCore _e20 = ll_psa_core(dot(n_2, f_3.u), dot(n_2, f_3.c_hat), _e13, _e16, _e19);
    p_2.core = _e20;
    float _e25 = p_2.core.total;
    p_2.inv_psa = (f_3.d / _e25);
    if (f_3.valid) {
        float _e33 = p_2.arc.width;
        local_18 = (_e33 > 0.0);
    } else {
        local_18 = false;
    }
    bool _e37 = local_18;
    if (_e37) {
        float _e42 = p_2.core.total;
        local_19 = (_e42 > 0.0);
    } else {
        local_19 = false;
    }
    bool _e46 = local_19;
    if (_e46) {
        float _e50 = p_2.inv_psa;
        local_20 = (_e50 > 0.0);
    } else {
        local_20 = false;
    }
    bool _e54 = local_20;
    if (_e54) {
        float _e58 = p_2.inv_psa;
        local_21 = (_e58 < 3e38);
    } else {
        local_21 = false;
    }
    bool _e62 = local_21;
    p_2.valid = _e62;
    LlPsa _e63 = p_2;
    const LlPsa llpsa = _e63;
    return llpsa;
}

LlPsa ll_psa_prepare(float3 begin_2, float3 end_2, float3 x_9, float3 n_3)
{
    float3 nn = normalize(n_3);
    const LlFrame _e5 = ll_frame(begin_2, end_2, x_9);
    const LlFrame _e6 = ll_frame_clip(_e5, nn);
    const LlPsa _e7 = ll_psa_on_frame(_e6, nn);
    const LlPsa llpsa_1 = _e7;
    return llpsa_1;
}

LlSample ll_psa_at(LlPsa p_3, float tau_10)
{
    LlPsaCore c_17 = p_3.core;
    const float2 _e5 = ll_sin_cos((0.5 * tau_10));
    float st = ((2.0 * _e5.x) * _e5.y);
    float ct = (1.0 - ((2.0 * _e5.x) * _e5.x));
    const float2 _e19 = ll_arc_rotate(p_3.arc, st, ct);
    float n_dot_w = ((c_17.p0_ * ct) + (c_17.p1_ * st));
    float3 dir_10 = ((_e19.x * p_3.arc.u) + (max(_e19.y, 0.0) * p_3.arc.c_hat));
    const LlSample llsample_1 = ConstructLlSample(dir_10, ((max(n_dot_w, 0.0) * p_3.inv_psa) * LL_PDF_SCALE));
    return llsample_1;
}

LlSample ll_psa_sample(LlPsa p_4, float xi_6)
{
    const float _e7 = ll_psa_solve(p_4.core, clamp(xi_6, 0.0, 1.0), LL_HALLEY_STEPS);
    const LlSample _e8 = ll_psa_at(p_4, _e7);
    const LlSample llsample_2 = _e8;
    return llsample_2;
}

float ll_psa_density_in_support(LlPsa p_5, float3 dir_4)
{
    return ((max(dot(p_5.n, dir_4), 0.0) * p_5.inv_psa) * LL_PDF_SCALE);
}

float ll_psa_pdf(LlPsa p_6, float3 dir_5)
{
    const float _e2 = ll_psa_density_in_support(p_6, dir_5);
    const bool _e4 = ll_arc_contains(p_6.arc, dir_5);
    return (_e4 ? _e2 : 0.0);
}

float ll_psa_inverse(LlPsa p_7, float3 dir_6)
{
    const float _e4 = ll_arc_tau(p_7.arc, dir_6);
    const float _e5 = ll_psa_cdf(p_7.core, _e4);
    return _e5;
}

float3x3 ll_shading_frame(float3 n_4, float3 v)
{
    float3 t_3 = (v - (dot(n_4, v) * n_4));
    float len = length(t_3);
    float sgn = ((n_4.z >= 0.0) ? 1.0 : -1.0);
    float k_6 = (-1.0 / (sgn + n_4.z));
    float3 any_ = float3(((n_4.x * n_4.y) * k_6), (sgn + ((n_4.y * n_4.y) * k_6)), -(n_4.y));
    float3 xh = ((len > 1e-7) ? (t_3 / (len).xxx) : any_);
    return float3x3(xh, cross(n_4, xh), n_4);
}

float3x3 ll_inverse3_(float3x3 m, float det)
{
    float3x3 r_3 = transpose(float3x3(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    return mul((1.0 / det), r_3);
}

LlLtc ll_ltc_prepare(float3 begin_3, float3 end_3, float3 x_10, float3x3 shading_frame, float3x3 a_9)
{
    LlLtc l = (LlLtc)0;
    float norm = 0.0;
    int i_2 = int(0);
    bool local_22 = (bool)0;
    bool local_23 = (bool)0;
    bool local_24 = (bool)0;
    bool local_25 = (bool)0;
    bool local_26 = (bool)0;
    bool local_27 = (bool)0;
    bool local_28 = (bool)0;

    float det_1 = determinant(a_9);
    uint2 loop_bound_2 = uint2(4294967295u, 4294967295u);
    bool loop_init_2 = true;
    while(true) {
        if (all(loop_bound_2 == uint2(0u, 0u))) { break; }
        loop_bound_2 -= uint2(loop_bound_2.y == 0u, 1u);
        if (!loop_init_2) {
            int _e31 = i_2;
            i_2 = asint(asuint(_e31) + asuint(int(1)));
        }
        loop_init_2 = false;
        int _e11 = i_2;
        if ((_e11 < int(3))) {
        } else {
            break;
        }
        {
            float _e14 = norm;
            int _e15 = i_2;
            int _e19 = i_2;
            int _e23 = i_2;
            norm = max(_e14, max(abs(a_9[min(uint(_e15), 2u)].x), max(abs(a_9[min(uint(_e19), 2u)].y), abs(a_9[min(uint(_e23), 2u)].z))));
        }
    }
    float _e36 = norm;
    float _e37 = norm;
    float _e39 = norm;
    bool conditioned = ((abs(det_1) * LL_MAX_ILL_CONDITION) > ((_e36 * _e37) * _e39));
    const float3x3 _e42 = ll_inverse3_(a_9, det_1);
    float3 n_5 = normalize(shading_frame[2]);
    l.to_shading = transpose(shading_frame);
    l.a = a_9;
    l.to_world = mul(_e42, shading_frame);
    const LlFrame _e50 = ll_frame(begin_3, end_3, x_10);
    float3 lobe_normal = mul(float3(a_9[0].z, a_9[1].z, a_9[2].z), shading_frame);
    const LlFrame _e59 = ll_frame_clip(_e50, n_5);
    const LlFrame _e60 = ll_frame_clip(_e59, lobe_normal);
    const LlArc _e62 = ll_arc(_e60);
    l.arc = _e62;
    float3x3 _e64 = l.to_shading;
    float3x3 to_cosine = mul(_e64, a_9);
    float3 pb = mul(((_e60.d * _e60.c_hat) + (_e60.l_b * _e60.u)), to_cosine);
    float3 pe = mul(((_e60.d * _e60.c_hat) + (_e60.l_e * _e60.u)), to_cosine);
    float3 up = float3(0.0, 0.0, 1.0);
    const LlFrame _e89 = ll_frame(pb, pe, (0.0).xxx);
    const LlFrame _e90 = ll_frame_clip(_e89, up);
    const LlPsa _e91 = ll_psa_on_frame(_e90, up);
    l.transformed = _e91;
    float3x3 _e93 = l.to_shading;
    float3x3 _e97 = l.to_shading;
    float3 m_3 = cross(mul(_e50.u, _e93), mul(_e50.c_hat, _e97));
    l.kappa = (length(mul(m_3, transpose(_e42))) / length(m_3));
    float _e109 = l.kappa;
    float _e114 = l.transformed.inv_psa;
    l.scale = ((_e109 * abs(det_1)) * _e114);
    if (conditioned) {
        local_22 = (det_1 != 0.0);
    } else {
        local_22 = false;
    }
    bool _e122 = local_22;
    if (_e122) {
        local_23 = _e60.valid;
    } else {
        local_23 = false;
    }
    bool _e127 = local_23;
    if (_e127) {
        bool _e132 = l.transformed.valid;
        local_24 = _e132;
    } else {
        local_24 = false;
    }
    bool _e134 = local_24;
    if (_e134) {
        float _e138 = l.kappa;
        local_25 = (_e138 > 0.0);
    } else {
        local_25 = false;
    }
    bool _e142 = local_25;
    if (_e142) {
        float _e146 = l.kappa;
        local_26 = (_e146 < 3e38);
    } else {
        local_26 = false;
    }
    bool _e150 = local_26;
    if (_e150) {
        float _e154 = l.scale;
        local_27 = (_e154 > 0.0);
    } else {
        local_27 = false;
    }
    bool _e158 = local_27;
    if (_e158) {
        float _e162 = l.scale;
        local_28 = (_e162 < 3e38);
    } else {
        local_28 = false;
    }
    bool _e166 = local_28;
    l.valid = _e166;
    LlLtc _e167 = l;
    const LlLtc llltc = _e167;
    return llltc;
}

float ll_ltc_density_on_clipped_line(LlLtc l_1, float3 dir_7)
{
    bool local_29 = (bool)0;

    float3 aw = mul(mul(dir_7, l_1.to_shading), l_1.a);
    float len2_ = dot(aw, aw);
    float p_10 = ((l_1.scale * max(aw.z, 0.0)) / (len2_ * len2_));
    if ((len2_ > 0.0)) {
        local_29 = (p_10 < 3e38);
    } else {
        local_29 = false;
    }
    bool _e23 = local_29;
    return (_e23 ? (p_10 * LL_PDF_SCALE) : 0.0);
}

float ll_ltc_pdf(LlLtc l_2, float3 dir_8)
{
    const float _e2 = ll_ltc_density_on_clipped_line(l_2, dir_8);
    const bool _e4 = ll_arc_contains(l_2.arc, dir_8);
    return (_e4 ? _e2 : 0.0);
}

float ll_ltc_tau_o(LlLtc l_3, float xi_7)
{
    bool local_30 = (bool)0;

    LlPsaCore core = l_3.transformed.core;
    if (!((xi_7 < LL_XI_GUARD))) {
        local_30 = (xi_7 > 0.99999);
    } else {
        local_30 = true;
    }
    bool _e12 = local_30;
    if (_e12) {
        const float _e13 = ll_psa_solve_converged(core, xi_7);
        return _e13;
    }
    const float _e15 = ll_psa_solve(core, xi_7, LL_HALLEY_STEPS);
    return _e15;
}

LlSample ll_ltc_sample(LlLtc l_4, float xi_in)
{
    float xi_8 = clamp(xi_in, LL_XI_LATTICE_START, LL_XI_LATTICE_END);
    const float _e6 = ll_ltc_tau_o(l_4, xi_8);
    const LlSample _e7 = ll_psa_at(l_4.transformed, _e6);
    float3 w_o_2 = _e7.dir;
    float3 w_2 = normalize(mul(w_o_2, l_4.to_world));
    const float _e14 = ll_arc_tau(l_4.arc, w_2);
    const float3 _e15 = ll_arc_direction(l_4.arc, _e14);
    const float _e16 = ll_ltc_density_on_clipped_line(l_4, _e15);
    const LlSample llsample_3 = ConstructLlSample(_e15, _e16);
    return llsample_3;
}

float ll_ltc_inverse(LlLtc l_5, float3 dir_9)
{
    float3 w_o_3 = normalize(mul(mul(dir_9, l_5.to_shading), l_5.a));
    const float _e8 = ll_psa_inverse(l_5.transformed, w_o_3);
    return _e8;
}

float ll_ltc_weight_scale(LlLtc l_6)
{
    return (1.0 / (l_6.transformed.inv_psa * l_6.kappa));
}

float ll_acos_unit(float c_15)
{
    float p_8 = -0.0012624911;

    float _e3 = p_8;
    p_8 = ((_e3 * c_15) + 0.00667009);
    float _e7 = p_8;
    p_8 = ((_e7 * c_15) - 0.017088126);
    float _e11 = p_8;
    p_8 = ((_e11 * c_15) + 0.03089188);
    float _e15 = p_8;
    p_8 = ((_e15 * c_15) - 0.050174303);
    float _e19 = p_8;
    p_8 = ((_e19 * c_15) + 0.08897899);
    float _e23 = p_8;
    p_8 = ((_e23 * c_15) - 0.2145988);
    float _e27 = p_8;
    p_8 = ((_e27 * c_15) + 1.5707963);
    float _e36 = p_8;
    return (sqrt(max((1.0 - c_15), 0.0)) * _e36);
}

float ll_ltc_record(uint k_3, uint lane)
{
    float _e7 = asfloat(ll_ltc_table.Load(((8u * k_3) + lane)*4));
    return _e7;
}

float ll_ltc_lerp(uint4 corners, float4 w, uint lane_1)
{
    const float _e5 = ll_ltc_record(corners.x, lane_1);
    const float _e9 = ll_ltc_record(corners.y, lane_1);
    const float _e14 = ll_ltc_record(corners.z, lane_1);
    const float _e19 = ll_ltc_record(corners.w, lane_1);
    return ((((w.x * _e5) + (w.y * _e9)) + (w.z * _e14)) + (w.w * _e19));
}

uint naga_div(uint lhs, uint rhs) {
    return lhs / (rhs == 0u ? 1u : rhs);
}

uint naga_f2u32(float value) {
    return uint(clamp(value, 0.0, 4294967000.0));
}

uint NagaBufferLength(ByteAddressBuffer buffer)
{
    uint ret;
    buffer.GetDimensions(ret);
    return ret;
}

LlLtcEntry ll_ltc_lookup(float alpha, float cos_theta_v)
{
    LlLtcEntry e_3 = (LlLtcEntry)0;

    uint size = naga_f2u32(round(sqrt(float(naga_div(((NagaBufferLength(ll_ltc_table) - 0) / 4), 8u)))));
    float last = float((size - 1u));
    float x_11 = (sqrt(clamp(alpha, 0.0, 1.0)) * last);
    const float _e21 = ll_acos_unit(clamp(cos_theta_v, 0.0, 1.0));
    float y_5 = min(((_e21 * 0.63661975) * last), last);
    uint i_3 = min(naga_f2u32(x_11), (size - 2u));
    uint j = min(naga_f2u32(y_5), (size - 2u));
    float fx = (x_11 - float(i_3));
    float fy = (y_5 - float(j));
    uint base = ((j * size) + i_3);
    float4 w_3 = float4(((1.0 - fx) * (1.0 - fy)), (fx * (1.0 - fy)), ((1.0 - fx) * fy), (fx * fy));
    uint4 corners_1 = uint4(base, (base + 1u), (base + size), ((base + size) + 1u));
    const float _e63 = ll_ltc_lerp(corners_1, w_3, 0u);
    const float _e65 = ll_ltc_lerp(corners_1, w_3, 3u);
    const float _e69 = ll_ltc_lerp(corners_1, w_3, 2u);
    const float _e74 = ll_ltc_lerp(corners_1, w_3, 1u);
    const float _e76 = ll_ltc_lerp(corners_1, w_3, 4u);
    e_3.a = float3x3(float3(_e63, 0.0, _e65), float3(0.0, _e69, 0.0), float3(_e74, 0.0, _e76));
    const float _e82 = ll_ltc_lerp(corners_1, w_3, 5u);
    e_3.rho = _e82;
    LlLtcEntry _e83 = e_3;
    const LlLtcEntry llltcentry = _e83;
    return llltcentry;
}

float ll_mis_ratio(float a_10, float b_2)
{
    return ((b_2 > 0.0) ? clamp((a_10 / b_2), 0.0, 1.0) : 0.0);
}

float ll_mis_balance(float p_s, float p_o)
{
    float m_4 = max(p_s, p_o);
    const float _e7 = ll_mis_ratio((p_s / m_4), ((p_s / m_4) + (p_o / m_4)));
    return ((m_4 > 0.0) ? _e7 : 0.0);
}

float ll_mis_power(float p_s_1, float p_o_1)
{
    float m_5 = max(p_s_1, p_o_1);
    float a_13 = (p_s_1 / m_5);
    float b_5 = (p_o_1 / m_5);
    const float _e9 = ll_mis_ratio((a_13 * a_13), ((a_13 * a_13) + (b_5 * b_5)));
    return ((m_5 > 0.0) ? _e9 : 0.0);
}

float ll_mis_weighted_balance(float p_s_2, float p_o_2, float w_s, float w_o)
{
    bool local_31 = (bool)0;

    float m_6 = max(p_s_2, p_o_2);
    float num = (w_s * (p_s_2 / m_6));
    float den_2 = (num + (w_o * (p_o_2 / m_6)));
    const float _e10 = ll_mis_balance(p_s_2, p_o_2);
    const float _e11 = ll_mis_ratio(num, den_2);
    if ((den_2 > 0.0)) {
        local_31 = (den_2 < 3e38);
    } else {
        local_31 = false;
    }
    bool _e19 = local_31;
    float weighted = (_e19 ? _e11 : _e10);
    return ((m_6 > 0.0) ? weighted : 0.0);
}

float ll_mis_clamped_optimal(float p_s_3, float p_o_3, float w_s_1, float w_o_1, float v_in)
{
    float v_2 = clamp(v_in, 0.0, 1.0);
    const float _e10 = ll_mis_balance(p_s_3, p_o_3);
    const float _e12 = ll_mis_weighted_balance(p_s_3, p_o_3, w_s_1, w_o_1);
    return (((1.0 - v_2) * _e10) + (v_2 * _e12));
}

float ll_bench_xi(uint pixel, uint k_4)
{
    uint h = (uint)0;

    h = ((pixel * 747796405u) + 2891336453u);
    uint _e7 = h;
    uint _e8 = h;
    uint _e14 = h;
    h = (((_e7 >> ((_e8 >> 28u) + 4u)) ^ _e14) * 277803737u);
    uint _e18 = h;
    uint _e21 = h;
    h = ((_e18 >> 22u) ^ _e21);
    uint _e23 = h;
    return frac(((float((_e23 >> 8u)) * 5.9604645e-8) + (float(k_4) * 0.618034)));
}

[numthreads(64, 1, 1)]
void certify(uint3 gid : SV_DispatchThreadID)
{
    float4 a0_ = (0.0).xxxx;
    float4 a1_ = (0.0).xxxx;
    float4 a2_ = (0.0).xxxx;

    uint k_7 = gid.x;
    uint _e4 = ll_params.count;
    if ((k_7 >= _e4)) {
        return;
    }
    float4 q0_ = asfloat(ll_queries.Load4((9u * k_7)*16));
    float4 q1_ = asfloat(ll_queries.Load4(((9u * k_7) + 1u)*16));
    float4 q2_ = asfloat(ll_queries.Load4(((9u * k_7) + 2u)*16));
    float4 q3_ = asfloat(ll_queries.Load4(((9u * k_7) + 3u)*16));
    float4 q4_ = asfloat(ll_queries.Load4(((9u * k_7) + 4u)*16));
    float4 q5_ = asfloat(ll_queries.Load4(((9u * k_7) + 5u)*16));
    float xi_9 = q0_.w;
    uint _e58 = ll_params.mode;
    switch(_e58) {
        case 0u: {
            const LlClipped _e63 = ll_clipped_prepare(q0_.xyz, q1_.xyz, q2_.xyz, q3_.xyz);
            if (_e63.valid) {
                const LlSample _e65 = ll_clipped_sample(_e63, xi_9);
                const float _e67 = ll_clipped_pdf(_e63, q5_.xyz);
                a0_ = float4(_e65.dir, _e65.pdf);
                const float _e72 = ll_clipped_inverse(_e63, _e65.dir);
                a1_ = float4(_e72, 1.0, _e67, _e67);
            }
            break;
        }
        case 1u: {
            const LlPsa _e79 = ll_psa_prepare(q0_.xyz, q1_.xyz, q2_.xyz, q3_.xyz);
            if (_e79.valid) {
                const LlSample _e81 = ll_psa_sample(_e79, xi_9);
                a0_ = float4(_e81.dir, _e81.pdf);
                const float _e86 = ll_psa_inverse(_e79, _e81.dir);
                const float _e88 = ll_psa_pdf(_e79, q5_.xyz);
                const float _e90 = ll_psa_density_in_support(_e79, q5_.xyz);
                a1_ = float4(_e86, 1.0, _e88, _e90);
            }
            break;
        }
        case 2u: {
            float4 _e99 = asfloat(ll_queries.Load4(((9u * k_7) + 6u)*16));
            float4 _e107 = asfloat(ll_queries.Load4(((9u * k_7) + 7u)*16));
            float4 _e115 = asfloat(ll_queries.Load4(((9u * k_7) + 8u)*16));
            float3x3 a_14 = transpose(float3x3(_e99.xyz, _e107.xyz, _e115.xyz));
            const float3x3 _e123 = ll_shading_frame(normalize(q3_.xyz), normalize(q4_.xyz));
            const LlLtc _e127 = ll_ltc_prepare(q0_.xyz, q1_.xyz, q2_.xyz, _e123, a_14);
            if (_e127.valid) {
                const LlSample _e129 = ll_ltc_sample(_e127, xi_9);
                a0_ = float4(_e129.dir, _e129.pdf);
                const float _e134 = ll_ltc_inverse(_e127, _e129.dir);
                const float _e136 = ll_ltc_pdf(_e127, q5_.xyz);
                const float _e138 = ll_ltc_density_on_clipped_line(_e127, q5_.xyz);
                a1_ = float4(_e134, 1.0, _e136, _e138);
                const float _e141 = ll_ltc_weight_scale(_e127);
                a2_ = float4(_e141, 0.0, 0.0, 0.0);
            }
            break;
        }
        case 3u: {
            const LlPsaCore _e151 = ll_psa_core(q0_.x, q0_.y, q0_.z, q1_.x, q1_.y);
            uint _e155 = ll_params.steps;
            const float _e156 = ll_psa_solve(_e151, q0_.w, _e155);
            a0_ = float4(_e156, _e151.total, _e151.p0_, _e151.p1_);
            break;
        }
        case 4u: {
            const float _e163 = ll_mis_balance(q0_.x, q0_.y);
            const float _e166 = ll_mis_power(q0_.x, q0_.y);
            const float _e171 = ll_mis_weighted_balance(q0_.x, q0_.y, q0_.z, q0_.w);
            const float _e177 = ll_mis_clamped_optimal(q0_.x, q0_.y, q0_.z, q0_.w, q1_.x);
            a0_ = float4(_e163, _e166, _e171, _e177);
            break;
        }
        case 5u: {
            const LlLtcEntry _e181 = ll_ltc_lookup(q1_.w, q2_.w);
            a0_ = float4(_e181.a[0].x, _e181.a[2].x, _e181.a[1].y, _e181.a[0].z);
            a1_ = float4(_e181.a[2].z, _e181.rho, 0.0, 0.0);
            break;
        }
        default: {
            break;
        }
    }
    float4 _e206 = a0_;
    ll_answers.Store4((3u * k_7)*16, asuint(_e206));
    float4 _e213 = a1_;
    ll_answers.Store4(((3u * k_7) + 1u)*16, asuint(_e213));
    float4 _e220 = a2_;
    ll_answers.Store4(((3u * k_7) + 2u)*16, asuint(_e220));
    return;
}

[numthreads(64, 1, 1)]
void bench(uint3 gid_1 : SV_DispatchThreadID)
{
    float sum = 0.0;
    uint k = 0u;
    uint k_1 = 0u;
    uint k_2 = 0u;

    uint pixel_1 = gid_1.x;
    uint _e4 = ll_params.count;
    if ((pixel_1 >= _e4)) {
        return;
    }
    float4 q0_1 = asfloat(ll_queries.Load4((3u * pixel_1)*16));
    float4 q1_1 = asfloat(ll_queries.Load4(((3u * pixel_1) + 1u)*16));
    float4 q2_1 = asfloat(ll_queries.Load4(((3u * pixel_1) + 2u)*16));
    float3 x_12 = q0_1.xyz;
    float3 n_6 = q1_1.xyz;
    float rho_d = q2_1.w;
    float4 _e30 = ll_params.light_begin;
    float3 lb = _e30.xyz;
    float4 _e34 = ll_params.light_end;
    float3 le = _e34.xyz;
    float big_k = ll_params.light_end.w;
    uint count = ll_params.samples;
    uint _e47 = ll_params.mode;
    switch(_e47) {
        case 0u: {
            const LlClipped _e48 = ll_clipped_prepare(lb, le, x_12, n_6);
            if (_e48.valid) {
                uint2 loop_bound_3 = uint2(4294967295u, 4294967295u);
                bool loop_init_3 = true;
                while(true) {
                    if (all(loop_bound_3 == uint2(0u, 0u))) { break; }
                    loop_bound_3 -= uint2(loop_bound_3.y == 0u, 1u);
                    if (!loop_init_3) {
                        uint _e69 = k;
                        k = (_e69 + 1u);
                    }
                    loop_init_3 = false;
                    uint _e52 = k;
                    if ((_e52 < count)) {
                    } else {
                        break;
                    }
                    {
                        uint _e54 = k;
                        const float _e55 = ll_bench_xi(pixel_1, _e54);
                        const LlSample _e56 = ll_clipped_sample(_e48, _e55);
                        float _e57 = sum;
                        sum = (_e57 + (((rho_d / LL_PI) * max(dot(n_6, _e56.dir), 0.0)) / _e56.pdf));
                    }
                }
            }
            break;
        }
        case 1u: {
            const LlPsa _e71 = ll_psa_prepare(lb, le, x_12, n_6);
            if (_e71.valid) {
                uint2 loop_bound_4 = uint2(4294967295u, 4294967295u);
                bool loop_init_4 = true;
                while(true) {
                    if (all(loop_bound_4 == uint2(0u, 0u))) { break; }
                    loop_bound_4 -= uint2(loop_bound_4.y == 0u, 1u);
                    if (!loop_init_4) {
                        uint _e92 = k_1;
                        k_1 = (_e92 + 1u);
                    }
                    loop_init_4 = false;
                    uint _e75 = k_1;
                    if ((_e75 < count)) {
                    } else {
                        break;
                    }
                    {
                        uint _e77 = k_1;
                        const float _e78 = ll_bench_xi(pixel_1, _e77);
                        const LlSample _e79 = ll_psa_sample(_e71, _e78);
                        float _e80 = sum;
                        sum = (_e80 + (((rho_d / LL_PI) * max(dot(n_6, _e79.dir), 0.0)) / _e79.pdf));
                    }
                }
            }
            break;
        }
        case 2u: {
            const LlPsa _e94 = ll_psa_prepare(lb, le, x_12, n_6);
            float3 v_3 = q2_1.xyz;
            const LlLtcEntry _e98 = ll_ltc_lookup(q0_1.w, dot(n_6, v_3));
            const float3x3 _e99 = ll_shading_frame(n_6, v_3);
            const LlLtc _e101 = ll_ltc_prepare(lb, le, x_12, _e99, _e98.a);
            if (_e94.valid) {
                float w_d = (max(rho_d, 0.01) / _e94.inv_psa);
                const float _e108 = ll_ltc_weight_scale(_e101);
                float w_s_2 = (_e101.valid ? (_e98.rho * _e108) : 0.0);
                uint2 loop_bound_5 = uint2(4294967295u, 4294967295u);
                bool loop_init_5 = true;
                while(true) {
                    if (all(loop_bound_5 == uint2(0u, 0u))) { break; }
                    loop_bound_5 -= uint2(loop_bound_5.y == 0u, 1u);
                    if (!loop_init_5) {
                        uint _e170 = k_2;
                        k_2 = (_e170 + 1u);
                    }
                    loop_init_5 = false;
                    uint _e115 = k_2;
                    if ((_e115 < count)) {
                    } else {
                        break;
                    }
                    {
                        uint _e117 = k_2;
                        const float _e118 = ll_bench_xi(pixel_1, _e117);
                        const LlSample _e119 = ll_psa_sample(_e94, _e118);
                        const float _e121 = ll_ltc_density_on_clipped_line(_e101, _e119.dir);
                        float ps = (_e101.valid ? _e121 : 0.0);
                        float fd = (((rho_d / LL_PI) * max(dot(n_6, _e119.dir), 0.0)) + (_e98.rho * ps));
                        float _e135 = sum;
                        const float _e138 = ll_mis_clamped_optimal(_e119.pdf, ps, w_d, w_s_2, 0.5);
                        sum = (_e135 + ((fd * _e138) / _e119.pdf));
                        if (_e101.valid) {
                            const LlSample _e147 = ll_ltc_sample(_e101, frac((_e118 + 0.5)));
                            const float _e149 = ll_psa_density_in_support(_e94, _e147.dir);
                            float fs = (((rho_d / LL_PI) * max(dot(n_6, _e147.dir), 0.0)) + (_e98.rho * _e147.pdf));
                            float _e161 = sum;
                            const float _e164 = ll_mis_clamped_optimal(_e147.pdf, _e149, w_s_2, w_d, 0.5);
                            sum = (_e161 + ((fs * _e164) / _e147.pdf));
                        }
                    }
                }
            }
            break;
        }
        default: {
            break;
        }
    }
    float _e174 = sum;
    ll_answers.Store4(pixel_1*16, asuint(float4(((big_k * _e174) / float(max(count, 1u))), 0.0, 0.0, 0.0)));
    return;
}
