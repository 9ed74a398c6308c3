/* What ln_svc_provider does with a request (its req.mode): shared by the
   provider (C) and the test drivers that call it (C++). */
#ifndef LN_TESTS_SVC_PROVIDER_MODES_H
#define LN_TESTS_SVC_PROVIDER_MODES_H

enum svc_provider_mode {
  ECHO = 0,
  SLOW = 1,
  USER_ERROR = 2,
  NO_RESPONSE = 3,
  LATER = 4,
  ERROR_TEXT = 5,
  CONCURRENCY = 6,
  RESPONDV = 7,        /* echoes the text through ln_service_request_respondv */
  RESPONDV_INVALID = 8 /* ln_service_request_respondv with a truncated response */
};

#endif
