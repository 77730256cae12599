//! The plain error metrics researchers report, of A against the reference B, over all pixels
//! and channels: MSE, relMSE = mean (m_A − m_B)²/(m_B² + ε), MAPE = mean |m_A − m_B|/(|m_B| + ε)
//! with ε = 0.01 (the usual guard of dark pixels). They measure distance, not evidence: MSE
//! includes the noise of both images, whose expectation `mse_noise` = mean (v_A + v_B) is given
//! alongside (MSE − mse_noise estimates the squared bias).

use linlight_imagefile::Image;
use serde::{Deserialize, Serialize};

/// ε of relMSE and MAPE.
pub const METRIC_EPSILON: f64 = 0.01;

#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct ErrorMetrics {
    pub mse: f64,
    /// E\[MSE\] for two unbiased images: mean of v_A + v_B.
    pub mse_noise: f64,
    pub rel_mse: f64,
    pub mape: f64,
}

/// Metrics of A against B (same size; not checked here).
pub fn error_metrics(a: &Image, b: &Image) -> ErrorMetrics {
    let mut m = ErrorMetrics::default();
    let mut n = 0usize;
    for (((ma, mb), va), vb) in a.mean.iter().zip(&b.mean).zip(&a.var).zip(&b.var) {
        for c in 0..3 {
            let (x, r) = (ma[c] as f64, mb[c] as f64);
            let d = x - r;
            m.mse += d * d;
            m.mse_noise += va[c] as f64 + vb[c] as f64;
            m.rel_mse += d * d / (r * r + METRIC_EPSILON);
            m.mape += d.abs() / (r.abs() + METRIC_EPSILON);
            n += 1;
        }
    }
    let k = 1.0 / n.max(1) as f64;
    ErrorMetrics {
        mse: m.mse * k,
        mse_noise: m.mse_noise * k,
        rel_mse: m.rel_mse * k,
        mape: m.mape * k,
    }
}
