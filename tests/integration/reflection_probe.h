// A real gRPC client of server reflection (grpc.reflection.v1alpha), without
// its generated stubs (Debian ships the service, not the client's headers):
// one request on the bidirectional stream through grpc::GenericStub, its
// bytes written and read by hand (the reflection messages are small).
#ifndef RISKPLAN_TESTS_INTEGRATION_REFLECTION_PROBE_H_
#define RISKPLAN_TESTS_INTEGRATION_REFLECTION_PROBE_H_

#include <chrono>
#include <memory>
#include <string>

#include "grpcpp/generic/generic_stub.h"
#include "grpcpp/grpcpp.h"

namespace riskplan::testing {

struct ReflectionAnswer {
  grpc::Status status;
  std::string response;  // the first response's bytes, if any
};

// Sends one ServerReflectionRequest: list_services when `symbol` is empty,
// else file_containing_symbol=`symbol`.
inline ReflectionAnswer AskReflection(const std::shared_ptr<grpc::Channel>& channel,
                                      const std::string& symbol = "") {
  std::string request;
  if (symbol.empty()) {
    request = std::string("\x3a\x00", 2);  // field 7 list_services = ""
  } else {
    request.push_back('\x22');  // field 4 file_containing_symbol
    request.push_back(static_cast<char>(symbol.size()));
    request += symbol;
  }
  grpc::GenericStub stub(channel);
  grpc::CompletionQueue cq;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  ReflectionAnswer answer;
  void* tag = nullptr;
  bool ok = false;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call = stub.PrepareCall(
      &context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  call->StartCall(reinterpret_cast<void*>(1));
  cq.Next(&tag, &ok);
  if (ok) {
    grpc::Slice slice(request);
    grpc::ByteBuffer out(&slice, 1);
    call->Write(out, reinterpret_cast<void*>(2));
    cq.Next(&tag, &ok);
  }
  if (ok) {
    call->WritesDone(reinterpret_cast<void*>(3));
    cq.Next(&tag, &ok);
  }
  grpc::ByteBuffer in;
  call->Read(&in, reinterpret_cast<void*>(4));
  cq.Next(&tag, &ok);
  if (ok) {
    grpc::Slice whole;
    if (in.TrySingleSlice(&whole).ok() || in.DumpToSingleSlice(&whole).ok()) {
      answer.response.assign(reinterpret_cast<const char*>(whole.begin()), whole.size());
    }
  }
  call->Finish(&answer.status, reinterpret_cast<void*>(5));
  do {
    cq.Next(&tag, &ok);
  } while (tag != reinterpret_cast<void*>(5));
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return answer;
}

}  // namespace riskplan::testing

#endif  // RISKPLAN_TESTS_INTEGRATION_REFLECTION_PROBE_H_
