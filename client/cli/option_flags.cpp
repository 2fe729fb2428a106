#include "client/cli/option_flags.h"

#include "common/errors.h"

namespace pbgi::cli {

void refuse_flag_alias(const options::FlagAlias& alias) { throw InvalidArgument(std::string(alias.error)); }

}  // namespace pbgi::cli
