//! PLY mesh import (placeholder; being written).
