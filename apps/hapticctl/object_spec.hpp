// SPDX-License-Identifier: Apache-2.0
// Scene objects written as words, for the command line and session scripts (docs/clients.md):
//   plane  normal=NX,NY,NZ [offset=M] [mode=unilateral|bilateral] [criterion=C | K=N/m B=Ns/m]
//   spring [constraint=point|line|plane] point=X,Y,Z [direction=DX,DY,DZ] (K=N/m [B=Ns/m] | criterion=C)
//   field  center=X,Y,Z radius=M [force=FX,FY,FZ] [jacobian=J11,J12,J13,J21,...,J33]
//   mesh   mesh=ID [position=X,Y,Z] [orientation=W,X,Y,Z] [criterion=C | K=N/m B=Ns/m] [static_friction=]
//          [dynamic_friction=] [shading=DEG]  (ID: a mesh this session uploaded; `hapticctl add mesh FILE` uploads
//          one; shading: force shading's crease angle in degrees, 0 .. 80)
// SI units (m, N, N/m, N s/m). A plane without gains asks for criterion=CE2. Only the form is checked here
// (known keys, finite numbers, vector lengths); the daemon checks the physics (unit normal, stability,
// device limits) and answers with the protocol's error codes.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "hapticd/client.hpp"

namespace hapticctl {

// A malformed object: the message names the word and the accepted form (exit code 2).
class SpecError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// `words` = the kind followed by key=value words. Throws SpecError.
hapticd::client::ObjectDescription parse_object_spec(const std::vector<std::string>& words);

// Splits a line into words at blanks (no quoting: no value contains a blank).
std::vector<std::string> split_words(const std::string& line);

}  // namespace hapticctl
