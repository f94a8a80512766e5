//! Battery catalogues: one pack per row.
//!
//! Columns (header names, any order; extra columns are ignored):
//!
//! | column | required | meaning |
//! | --- | --- | --- |
//! | `name` | yes | product name |
//! | `cells` | yes | cells in series (3 for a 3S pack) |
//! | `capacity_mah` | yes | rated capacity, mAh |
//! | `mass_g` | yes | pack mass with leads, g |
//! | `energy_wh` | no | stored energy, Wh |
//! | `energy_density_wh_per_kg` | no | energy per mass, Wh/kg (used when `energy_wh` is empty) |
//! | `source` | no | where mass and capacity come from |
//!
//! Energy is taken from `energy_wh`, else `energy_density_wh_per_kg × mass`, else
//! `cells × 3.7 V × capacity` (the nominal LiPo cell voltage), and the pack says which.

use crate::{ImportError, Table};

/// How a pack's energy was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnergyBasis {
    /// From the `energy_wh` column.
    Stated,
    /// From `energy_density_wh_per_kg × mass`.
    Density,
    /// From `cells × 3.7 V × capacity`.
    Rating,
}

/// One catalogue row.
#[derive(Debug, Clone, PartialEq)]
pub struct Pack {
    /// Product name.
    pub name: String,
    /// Cells in series.
    pub cells: u8,
    /// Rated capacity, mAh.
    pub capacity_mah: f64,
    /// Mass, g.
    pub mass_g: f64,
    /// Stored energy, Wh.
    pub energy_wh: f64,
    /// Where `energy_wh` came from.
    pub energy_basis: EnergyBasis,
    /// The `source` column, if any.
    pub source: Option<String>,
    /// Line in the file.
    pub line: u64,
}

impl Table {
    /// Reads the table as a battery catalogue.
    pub fn catalogue(&self) -> Result<Vec<Pack>, ImportError> {
        let names = self.text_column("name")?;
        let mut packs = Vec::with_capacity(self.len());
        for (r, name) in names.iter().enumerate() {
            let num = |col: &str| self.cell_number(r, col);
            let opt = |col: &str| -> Result<Option<f64>, ImportError> {
                if self.has(col) && !self.cell_text(r, col).is_empty() {
                    num(col).map(Some)
                } else {
                    Ok(None)
                }
            };
            let cells_f = num("cells")?;
            if !(1.0..=24.0).contains(&cells_f) || cells_f.fract() != 0.0 {
                return Err(self.bad_value(r, "cells", "a whole number of cells from 1 to 24"));
            }
            let capacity_mah = num("capacity_mah")?;
            let mass_g = num("mass_g")?;
            if capacity_mah <= 0.0 {
                return Err(self.bad_value(r, "capacity_mah", "a capacity greater than zero"));
            }
            if mass_g <= 0.0 {
                return Err(self.bad_value(r, "mass_g", "a mass greater than zero"));
            }
            let cells = cells_f as u8;
            let (energy_wh, energy_basis) =
                match (opt("energy_wh")?, opt("energy_density_wh_per_kg")?) {
                    (Some(e), _) if e > 0.0 => (e, EnergyBasis::Stated),
                    (Some(_), _) => {
                        return Err(self.bad_value(r, "energy_wh", "an energy greater than zero"));
                    }
                    (None, Some(d)) if d > 0.0 => (d * mass_g / 1000.0, EnergyBasis::Density),
                    (None, Some(_)) => {
                        return Err(self.bad_value(
                            r,
                            "energy_density_wh_per_kg",
                            "a density greater than zero",
                        ));
                    }
                    (None, None) => (
                        estimator::pack_energy_wh(
                            cells,
                            capacity_mah,
                            estimator::LIPO_NOMINAL_CELL_V,
                        ),
                        EnergyBasis::Rating,
                    ),
                };
            if name.is_empty() {
                return Err(self.bad_value(r, "name", "a pack name"));
            }
            packs.push(Pack {
                name: (*name).to_owned(),
                cells,
                capacity_mah,
                mass_g,
                energy_wh,
                energy_basis,
                source: self
                    .has("source")
                    .then(|| self.cell_text(r, "source").to_owned())
                    .filter(|s| !s.is_empty()),
                line: self.line(r),
            });
        }
        Ok(packs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn catalogues_never_panic(
            rows in proptest::collection::vec("[A-Za-z ]{0,6},[-0-9.]{0,4},[-0-9.e]{0,6},[-0-9.]{0,5},[-0-9.]{0,4},[-0-9.]{0,4}", 0..6)
        ) {
            let text = format!("name,cells,capacity_mah,mass_g,energy_wh,energy_density_wh_per_kg\n{}\n", rows.join("\n"));
            if let Ok(t) = Table::parse(text.as_bytes(), "fuzz.csv") {
                if let Ok(packs) = t.catalogue() {
                    for p in packs {
                        prop_assert!(p.energy_wh > 0.0 && p.mass_g > 0.0 && p.cells >= 1);
                    }
                }
            }
        }
    }

    #[test]
    fn energy_from_each_basis() {
        let t = Table::parse(
            b"name,cells,capacity_mah,mass_g,energy_wh,energy_density_wh_per_kg\n\
              A,3,2100,144,,164\nB,3,1320,85,15,\nC,2,1000,60,,\n",
            "c.csv",
        )
        .unwrap();
        let p = t.catalogue().unwrap();
        assert!((p[0].energy_wh - 23.616).abs() < 1e-9);
        assert_eq!(p[0].energy_basis, EnergyBasis::Density);
        assert_eq!(p[1].energy_wh, 15.0);
        assert!((p[2].energy_wh - 7.4).abs() < 1e-9);
        assert_eq!(p[2].energy_basis, EnergyBasis::Rating);
    }

    #[test]
    fn bad_rows_name_line_and_column() {
        let t = Table::parse(b"name,cells,capacity_mah,mass_g\nA,3.5,100,10\n", "c.csv").unwrap();
        let e = t.catalogue().unwrap_err().to_string();
        assert_eq!(
            e,
            "c.csv, line 2, column \"cells\": \"3.5\" is not a whole number of cells from 1 to 24"
        );
        let t = Table::parse(b"name,cells,mass_g\nA,3,10\n", "c.csv").unwrap();
        assert!(
            t.catalogue()
                .unwrap_err()
                .to_string()
                .contains("no column \"capacity_mah\"")
        );
    }
}
