// BSDF parameter sets that several tests share.
#pragma once

#include "luz/bsdf/bsdf.h"

namespace luz_test {

// The example of Mitsuba 3's principled documentation (every lobe), with
// spec_trans as given (the documentation's is 0.4; > 0 makes the
// transmissive model).
inline luz::Bsdf principled_doc_example(float spec_trans) {
  luz::PrincipledParams p;
  p.base_color = {1.f, 1.f, 1.f};
  p.metallic = .7f;
  p.eta = luz::PrincipledParams::specular_to_eta(.6f);
  p.roughness = .2f;
  p.spec_tint = .4f;
  p.anisotropic = .5f;
  p.sheen = .3f;
  p.sheen_tint = .2f;
  p.clearcoat = .6f;
  p.clearcoat_gloss = .3f;
  p.spec_trans = spec_trans;
  return luz::Bsdf::make_principled(p, spec_trans > 0.f);
}

// The example of Mitsuba 3's principledthin documentation.
inline luz::Bsdf principledthin_doc_example() {
  luz::PrincipledThinBsdf p;
  p.base_color = {.7f, .1f, .1f};
  p.roughness = .15f;
  p.spec_tint = .1f;
  p.anisotropic = .5f;
  p.spec_trans = .8f;
  p.diff_trans = .3f;
  p.eta = 1.33f;
  return luz::Bsdf::make_principled_thin(p);
}

}  // namespace luz_test
