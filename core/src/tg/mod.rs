//! Tri-grid files (placeholder).
