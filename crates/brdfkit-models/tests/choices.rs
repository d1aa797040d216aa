//! Structural choices of the models parse back from their names.

use brdfkit_models::cook_torrance::{Fresnel, FresnelKind};
use brdfkit_models::ward::Normalization;

#[test]
fn fresnel_kinds_and_normalisations_parse_from_their_names() {
    for k in FresnelKind::ALL {
        assert_eq!(k.name().parse::<FresnelKind>().unwrap(), k);
        assert_eq!(k.with_defaults().kind(), k);
    }
    assert_eq!(Fresnel::DEFAULT.kind(), FresnelKind::Schlick);
    for n in Normalization::ALL {
        assert_eq!(n.name().parse::<Normalization>().unwrap(), n);
    }
    assert_eq!(
        "fresnell".parse::<FresnelKind>().unwrap_err().to_string(),
        "unknown fresnel `fresnell` (expected none, schlick, conductor, dielectric)"
    );
}
