// Placeholders so the tree links while the io issue is in progress. Delete each function as
// its real implementation lands.
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/util/check.h"

namespace udvr {}  // namespace udvr
